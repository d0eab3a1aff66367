"""Iterative masked sampling: how a :class:`~mcnkit.completion.nets.MaskedSampler` draws whole maps, and the
partly revealed maps it is trained on.

Drawing (:func:`draw`): every unknown cell of m_t gets a uniform random priority; round ``r`` of the schedule
draws the label of each cell whose priority is below ``schedule[r]`` and was not drawn before, from the net's
p(occupied) given m_t *and every label drawn so far*, and writes it into the input as if observed.  The first
rounds draw a few scattered cells, which settle the house's extent; the last rounds fill in cells whose
neighbourhood is already drawn.  Each draw conditions on the earlier ones, so the K samples of one m_t are K
different, whole houses, and a cell's share of "free" over many samples is the net's calibrated probability.
Cells known in m_t are never changed.

Training (:func:`reveal_for_training`): the net must meet, in training, the inputs it meets while drawing: m_t
with a random share of its unknown cells set to their true labels (from m_T), the share spread over the schedule
like the drawing rounds.  The loss (:func:`masked_bce`) is the binary cross-entropy of p(occupied) on the cells
still unknown, a proper scoring rule, so the net's probabilities stay calibrated.

Example:
    >>> from mcnkit.completion.nets import MaskedSampler, SamplerConfig, UNetConfig
    >>> net = MaskedSampler(SamplerConfig(UNetConfig(out_channels=1, base_channels=4, depth=2, dropout=0.0))).eval()
    >>> x = torch.stack([torch.full((1, 16, 16), 0.5), torch.ones(1, 16, 16)], dim=1)   # all unknown
    >>> draw(net.net, x, k=3, schedule=(0.25, 1.0), generator=torch.Generator().manual_seed(0))[0].shape
    torch.Size([1, 3, 16, 16])
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from torch.nn import functional as F

from mcnkit.completion.structure import separating_walls

__all__ = ["draw", "masked_bce", "reveal_for_training", "reveal_share"]

Net = Callable[[torch.Tensor], torch.Tensor]


def reveal_share(t: torch.Tensor, schedule: Sequence[float]) -> torch.Tensor:
    """The share of unknown cells drawn at time ``t`` ∈ [0, rounds] of the schedule (piecewise linear): round
    ``r`` starts at ``t = r`` with the share drawn before it (0, schedule[0], …)."""
    knots = torch.tensor([0.0, *schedule[:-1]], dtype=t.dtype, device=t.device)
    r = t.floor().long().clamp(0, len(knots) - 1)
    nxt = torch.tensor([*schedule], dtype=t.dtype, device=t.device)
    return knots[r] + (t - r.to(t.dtype)).clamp(0.0, 1.0) * (nxt[r] - knots[r])


def reveal_for_training(
    x: torch.Tensor, y: torch.Tensor, schedule: Sequence[float], generator: torch.Generator | None = None
) -> tuple[torch.Tensor, torch.Tensor]:
    """(input with a random share of m_t's unknown cells set to m_T's labels, the cells still unknown (B, 1, H, W)).

    ``x`` (B, 2, H, W) = m_t (image, mask); ``y`` (B, 2, H, W) = m_T.  The share per map is drawn uniformly over
    the schedule's time (each round as likely as the others), and the cells uniformly among the unknown ones.
    """
    b = x.shape[0]
    t = torch.rand(b, generator=generator) * len(schedule)
    share = reveal_share(t, schedule).to(x.device).view(b, 1, 1, 1)
    unknown = x[:, 1:2] > 0.5
    revealed = unknown & (torch.rand(unknown.shape, generator=generator).to(x.device) < share)
    image = torch.where(revealed, y[:, :1], x[:, :1])
    mask = torch.where(revealed, torch.zeros_like(x[:, 1:2]), x[:, 1:2])
    return torch.cat([image, mask], dim=1), unknown & ~revealed


def masked_bce(p_occupied: torch.Tensor, target_occupied: torch.Tensor, cells: torch.Tensor) -> torch.Tensor:
    """Mean binary cross-entropy of p(occupied) (B, 1, H, W) against the 0/1 target over ``cells`` (bool)."""
    p = p_occupied.clamp(1e-6, 1.0 - 1e-6)
    loss = F.binary_cross_entropy(p, target_occupied, reduction="none")
    w = cells.to(loss.dtype)
    return (loss * w).sum() / w.sum().clamp_min(1.0)


@torch.no_grad()
def draw(
    net: Net,
    x: torch.Tensor,
    k: int,
    schedule: Sequence[float],
    generator: torch.Generator | None = None,
    late_temperature: float = 1.0,
    late_from: float = 1.0,
    settle: Sequence[float] = (),
    reconnect: int = 0,
) -> tuple[torch.Tensor, torch.Tensor]:
    """(K sampled maps (B, K, H, W) with 0 (free) / 1 (occupied) on m_t's unknown cells and m_t's own values
    elsewhere, the first round's p(occupied | m_t) (B, 1, H, W)).

    ``net`` maps (N, 2, H, W) to p(occupied) (N, 1, H, W); ``x`` (B, 2, H, W) = m_t.  Rounds starting once
    ``late_from`` of the cells are drawn use p sharpened by ``late_temperature``; each share in ``settle`` is one
    sweep setting that share of the cells to their most likely label given all the others; last, up to
    ``reconnect`` times, the walls that cut a sample's free space apart are masked and drawn again given
    everything else (see :class:`~mcnkit.completion.nets.SamplerConfig`).
    """
    b, _, h, w = x.shape
    first = net(x)  # the first round sees m_t alone: one pass per map serves all K samples
    state = x.unsqueeze(1).expand(b, k, 2, h, w).reshape(b * k, 2, h, w).clone()
    unknown = state[:, 1:2] > 0.5
    priority = torch.rand(unknown.shape, generator=generator).to(x.device)
    done = 0.0
    for r, share in enumerate(schedule):
        p = first.unsqueeze(1).expand(b, k, 1, h, w).reshape(b * k, 1, h, w) if r == 0 else net(state)
        if done >= late_from and late_temperature != 1.0:
            p = _sharpen(p, late_temperature)
        now = unknown & (priority >= done) & (priority < share if share < 1.0 else torch.ones_like(unknown))
        label = (torch.rand(p.shape, generator=generator).to(x.device) < p).to(state.dtype)
        _commit(state, now, label)
        done = share
    for share in settle:
        now = unknown & (torch.rand(unknown.shape, generator=generator).to(x.device) < share)
        masked = state.clone()
        _commit(masked, now, torch.full_like(masked[:, :1], 0.5), known=False)
        _commit(state, now, (net(masked) >= 0.5).to(state.dtype))
    for _ in range(reconnect):
        walls = torch.from_numpy(separating_walls(state[:, 0].cpu().numpy(), unknown[:, 0].cpu().numpy()))
        redo = walls.flatten(1).any(1)
        if not bool(redo.any()):
            break
        cells = walls[redo].unsqueeze(1).to(x.device)
        sub = state[redo]
        masked = sub.clone()
        _commit(masked, cells, torch.full_like(masked[:, :1], 0.5), known=False)
        label = (torch.rand(cells.shape, generator=generator).to(x.device) < net(masked)).to(state.dtype)
        _commit(sub, cells, label)
        state[redo] = sub
    return state[:, 0].reshape(b, k, h, w), first


def _commit(state: torch.Tensor, cells: torch.Tensor, image: torch.Tensor, known: bool = True) -> None:
    """Writes ``image`` into ``cells`` of the (N, 2, H, W) state, marked known (mask 0) or unknown (mask 1)."""
    state[:, :1] = torch.where(cells, image, state[:, :1])
    state[:, 1:2] = torch.where(cells, torch.full_like(image, 0.0 if known else 1.0), state[:, 1:2])


def _sharpen(p: torch.Tensor, temperature: float) -> torch.Tensor:
    """p(occupied) with its log-odds divided by ``temperature``."""
    q = p.clamp(1e-6, 1.0 - 1e-6)
    return torch.sigmoid((torch.log(q) - torch.log1p(-q)) / temperature)
