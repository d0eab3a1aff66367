"""Completion and real sampling: ``m_s ~ p_g(m | m_t)``.

:func:`complete` gives the deterministic completion (dropout off).  :func:`sample_completions` draws ``K``
completions per input in one batch of ``B·K`` with dropout kept on (and noise channels drawn, if the net has
any) from an injected :class:`torch.Generator`; it returns the ternary sample stack, the mean network output
and its ternary map, and a per-cell uncertainty = entropy of the K sampled labels (free / occupied / unknown)
divided by log 3 (0: all samples agree, 1: labels spread evenly).  :func:`diversity` is the mean over pairs of
samples of the share of cells on which they differ.

Fast path: both functions run a frozen inference copy of the net (:func:`inference_net`): spectral norm
evaluated once (W/σ stored as a plain weight) and eval-mode batch norm folded into the preceding (transposed)
convolution, weights in channels-last layout (on which oneDNN runs these thin layers faster).  It computes the same
function as ``net`` in eval mode (up to float rounding), is cached per net and rebuilt whenever any of the net's
parameters or buffers changed (``Tensor._version``); checkpoints are untouched.

Example:
    >>> net = UNet(UNetConfig(base_channels=4, depth=2)).eval()
    >>> s = sample_completions(net, np.full((1, 64, 64), 0.5, np.float32), k=3, generator=torch.Generator().manual_seed(0))
    >>> s.samples.shape
    (1, 3, 64, 64)
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn
from torch.nn.utils import parametrize

from mcnkit.completion.masked import draw
from mcnkit.completion.nets import CompletionNet, MaskedSampler, UNet, occupancy_output
from mcnkit.grid import network_to_ternary, ternary_to_network
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = [
    "SampleSet",
    "complete",
    "diversity",
    "inference_net",
    "label_entropy",
    "network_outputs",
    "sample_completions",
]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class SampleSet:
    """``samples`` (B, K, H, W) ternary; ``mean_output`` (B, 2, H, W); ``mean`` (B, H, W) ternary of the mean
    output; ``uncertainty`` (B, H, W) in [0, 1]."""

    samples: F32
    mean_output: F32
    mean: F32
    uncertainty: F32

    @property
    def diversity(self) -> F32:
        """Per input, the mean share of cells on which two samples differ (B,)."""
        return diversity(self.samples)


def _as_input(partial: NDArray[np.floating] | torch.Tensor, device: torch.device) -> torch.Tensor:
    if isinstance(partial, torch.Tensor):
        x = partial
        if x.ndim == 3:
            x = torch.stack([x, (x == UNKNOWN).to(x.dtype)], dim=1)
    else:
        x = torch.from_numpy(ternary_to_network(np.asarray(partial, np.float32)))
    return x.to(device=device, dtype=torch.float32)


_FROZEN: weakref.WeakKeyDictionary[nn.Module, tuple[tuple[int, ...], CompletionNet]] = weakref.WeakKeyDictionary()


def _fingerprint(net: nn.Module) -> tuple[int, ...]:
    """Identity and in-place version of every weight.  Tensors made under ``torch.inference_mode`` (a net loaded
    there) keep no version: for them only a replaced tensor counts as a change."""
    return tuple(
        v for t in (*net.parameters(), *net.buffers()) for v in (id(t), -1 if t.is_inference() else t._version)
    )


def _fold_bn(conv: nn.Module, bn: nn.BatchNorm2d) -> None:
    """conv ← bn ∘ conv (eval-mode statistics); the out channels are dim 0 (Conv2d) or dim 1 (ConvTranspose2d)."""
    assert isinstance(conv, nn.Conv2d | nn.ConvTranspose2d)
    assert bn.running_mean is not None and bn.running_var is not None
    scale = (bn.weight if bn.affine else torch.ones_like(bn.running_var)) / torch.sqrt(bn.running_var + bn.eps)
    shift = bn.bias if bn.affine else torch.zeros_like(bn.running_mean)
    dim = 1 if isinstance(conv, nn.ConvTranspose2d) else 0
    shape = [1] * conv.weight.ndim
    shape[dim] = -1
    conv.weight = nn.Parameter(conv.weight * scale.view(shape), requires_grad=False)
    bias = conv.bias if conv.bias is not None else torch.zeros_like(bn.running_mean)
    conv.bias = nn.Parameter((bias - bn.running_mean) * scale + shift, requires_grad=False)


_PHASE_TAPS = ((3, 1, None), (None, 2, 0))
"""For output phase a (row 2m + a) of a ConvTranspose2d(kernel 4, stride 2, padding 1): the kernel index that
input row m - 1, m, m + 1 meets (None: none)."""


class SubPixelUp(nn.Module):
    """A ConvTranspose2d(kernel 4, stride 2, padding 1) rewritten as a 3 × 3 convolution to 4 × the channels and
    a pixel shuffle: the same function up to float rounding, which CPU convolution libraries run faster than a
    transposed convolution."""

    def __init__(self, deconv: nn.ConvTranspose2d) -> None:
        super().__init__()
        if (deconv.kernel_size, deconv.stride, deconv.padding, deconv.output_padding) != ((4, 4), (2, 2), (1, 1), (0, 0)):
            raise ValueError(f"SubPixelUp rewrites kernel 4, stride 2, padding 1 only, got {deconv}")
        w = deconv.weight.detach()  # (C_in, C_out, 4, 4)
        c_in, c_out = w.shape[:2]
        sub = w.new_zeros(c_out, 2, 2, c_in, 3, 3)
        for a, rows in enumerate(_PHASE_TAPS):
            for b, cols in enumerate(_PHASE_TAPS):
                for t, kt in enumerate(rows):
                    for u, ku in enumerate(cols):
                        if kt is not None and ku is not None:
                            sub[:, a, b, :, t, u] = w[:, :, kt, ku].T
        self.conv = nn.Conv2d(c_in, 4 * c_out, 3, padding=1).to(device=w.device, dtype=w.dtype)
        self.conv.weight = nn.Parameter(sub.reshape(4 * c_out, c_in, 3, 3), requires_grad=False)
        bias = deconv.bias.detach() if deconv.bias is not None else w.new_zeros(c_out)
        self.conv.bias = nn.Parameter(bias.repeat_interleave(4), requires_grad=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.pixel_shuffle(self.conv(x), 2)


def _freeze(net: UNet, subpixel: bool = False) -> UNet:
    """The inference copy of ``net``; ``subpixel`` also rewrites its upsampling layers as :class:`SubPixelUp` (for
    the masked sampler, which runs its net once per round; the deterministic nets keep theirs, so their outputs
    stay bit for bit those their experiments report)."""
    # A fresh net (its own parametrized classes: never remove_parametrizations on a deepcopy, whose classes are
    # shared with the original) with the parametrizations removed, then the evaluated weights copied in.
    was_training = net.training
    net.eval()  # eval: reading a spectral-norm weight runs no power iteration
    frozen = UNet(net.config).eval()
    src_param = next(net.parameters(), None)
    if src_param is not None:
        frozen.to(device=src_param.device, dtype=src_param.dtype)
    with torch.no_grad():
        for m in frozen.modules():
            if parametrize.is_parametrized(m, "weight"):
                parametrize.remove_parametrizations(m, "weight", leave_parametrized=False)
        kinds = nn.Conv2d | nn.ConvTranspose2d | nn.BatchNorm2d
        srcs = [m for m in net.modules() if isinstance(m, kinds)]
        dsts = [m for m in frozen.modules() if isinstance(m, kinds)]
        for src, dst in zip(srcs, dsts, strict=True):
            if isinstance(src, nn.BatchNorm2d):
                dst.load_state_dict(src.state_dict())
            else:
                dst.weight.copy_(src.weight)
                if src.bias is not None and dst.bias is not None:
                    dst.bias.copy_(src.bias)
        for convs, norms in ((frozen.down, frozen.down_norm), (frozen.up, frozen.up_norm)):
            for i, (conv, norm) in enumerate(zip(convs, norms, strict=True)):
                if isinstance(norm, nn.BatchNorm2d):
                    _fold_bn(conv, norm)
                    norms[i] = nn.Identity()
        if subpixel:
            for i, deconv in enumerate(frozen.up):
                if isinstance(deconv, nn.ConvTranspose2d):
                    frozen.up[i] = SubPixelUp(deconv)
    # NHWC: oneDNN runs these thin layers faster on it.
    frozen.to(memory_format=torch.channels_last)  # type: ignore[call-overload]  # (missing from torch's stubs)
    net.train(was_training)
    for p in frozen.parameters():
        p.requires_grad_(False)
    return frozen


def inference_net(net: CompletionNet) -> CompletionNet:
    """The frozen inference copy of ``net`` (cached; rebuilt when its weights change): a plain :class:`UNet`, or a
    :class:`MaskedSampler` around one.  Other nets (wrappers, subclasses) are returned unchanged."""
    if type(net) not in (UNet, MaskedSampler):
        return net
    key = _fingerprint(net)
    hit = _FROZEN.get(net)
    if hit is not None and hit[0] == key:
        return hit[1]
    frozen: CompletionNet
    if isinstance(net, MaskedSampler):
        frozen = MaskedSampler(net.config).eval()
        frozen.net = _freeze(net.net, subpixel=True)
    else:
        frozen = _freeze(net)
    _FROZEN[net] = (key, frozen)
    return frozen


def _symmetric_output(net: CompletionNet, x: torch.Tensor, transpose: bool = True) -> torch.Tensor:
    """Mean of the outputs over the symmetries of the square (each undone on its output); x square.  The 8
    symmetries, or with ``transpose=False`` the 4 flips (what a net trained with ``--flips-only`` has seen)."""
    transposes = (False, True) if transpose else (False,)
    ops = [(t, dims) for t in transposes for dims in ((), (-1,), (-2,), (-2, -1))]
    total = torch.zeros((x.shape[0], 2, *x.shape[2:]), dtype=x.dtype, device=x.device)
    for t, dims in ops:
        xi = x.transpose(-1, -2) if t else x
        yi = net(xi.flip(dims) if dims else xi)
        yi = yi.flip(dims) if dims else yi
        total += yi.transpose(-1, -2) if t else yi
    return total / len(ops)


@torch.inference_mode()
def network_outputs(
    net: CompletionNet,
    partial: NDArray[np.floating],
    device: torch.device | str = "cpu",
    batch_size: int = 256,
    symmetric: bool = False,
    transpose: bool = True,
) -> F32:
    """The net's deterministic outputs (N, 2, H, W) in [0, 1] for m_t (N, H, W); the net is used in eval mode.

    ``symmetric``: the mean output over the symmetries of the square (8× the cost; ``transpose=False``: over the 4
    flips, 4× the cost).
    """
    fast = inference_net(net)  # always in eval mode; ``net`` itself is not touched (no mode switches)
    was_training = net.training
    if fast is net:
        net.eval()
    dev = torch.device(device)
    outs = []
    for i in range(0, len(partial), batch_size):
        x = _as_input(partial[i : i + batch_size], dev)
        outs.append((_symmetric_output(fast, x, transpose) if symmetric else fast(x)).cpu().numpy())
    if fast is net:
        net.train(was_training)
    if not outs:
        return np.zeros((0, 2, *np.shape(partial)[1:]), np.float32)
    return np.concatenate(outs)


def complete(
    net: CompletionNet,
    partial: NDArray[np.floating],
    device: torch.device | str = "cpu",
    batch_size: int = 256,
    symmetric: bool = False,
    transpose: bool = True,
) -> F32:
    """Deterministic completions (N, H, W) ternary of m_t (N, H, W): :func:`network_outputs` converted by the
    paper's rule."""
    return network_to_ternary(network_outputs(net, partial, device, batch_size, symmetric, transpose))


def label_entropy(samples: NDArray[np.floating]) -> F32:
    """Entropy of the labels along axis 1 of (B, K, H, W) ternary samples, divided by log 3 → (B, H, W)."""
    s = np.asarray(samples)
    k = s.shape[1]
    ent = np.zeros((s.shape[0], *s.shape[2:]), np.float64)
    for v in (FREE, UNKNOWN, OCCUPIED):
        p = (s == v).sum(axis=1) / k
        ent -= np.where(p > 0, p * np.log(np.maximum(p, 1e-12)), 0.0)
    return (ent / np.log(3.0)).astype(np.float32)


def diversity(samples: NDArray[np.floating]) -> F32:
    """Mean over the K(K−1)/2 pairs of samples of the share of cells on which they differ → (B,)."""
    s = np.asarray(samples)
    k = s.shape[1]
    if k < 2:
        return np.zeros(s.shape[0], np.float32)
    total = np.zeros(s.shape[0], np.float64)
    for i in range(k):
        for j in range(i + 1, k):
            total += (s[:, i] != s[:, j]).mean(axis=(-2, -1))
    return (total / (k * (k - 1) / 2)).astype(np.float32)


@torch.inference_mode()
def sample_completions(
    net: CompletionNet,
    partial: NDArray[np.floating] | torch.Tensor,
    k: int = 8,
    generator: torch.Generator | None = None,
    device: torch.device | str = "cpu",
) -> SampleSet:
    """K sampled completions of each m_t (B, H, W) [or network input (B, 2, H, W)], all in one batch.

    A :class:`MaskedSampler` draws each sample round by round (:func:`mcnkit.completion.masked.draw`); its
    ``mean_output`` is its p(occupied | m_t), which the samples' share of "occupied" estimates.  A :class:`UNet`
    draws all K in one pass with dropout on (and noise channels drawn, if it has any).
    """
    if k < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    fast = inference_net(net)  # eval mode: batch norm uses its running statistics; dropout on through sample=True
    was_training = net.training
    if fast is net:
        net.eval()
    x = _as_input(partial, torch.device(device))
    b, c, h, w = x.shape
    if isinstance(fast, MaskedSampler):
        cfg = net.config if isinstance(net, MaskedSampler) else fast.config  # the drawing settings of the net itself
        drawn, first = draw(fast.net, x, k, cfg.schedule, generator, cfg.late_temperature, cfg.late_from, cfg.settle,
                            cfg.reconnect)
        samples = np.where(drawn.cpu().numpy() >= 0.5, OCCUPIED, FREE).astype(np.float32)  # (B, K, H, W)
        known = (x[:, 1] < 0.5).cpu().numpy()[:, None]
        samples = np.where(known, x[:, None, 0].cpu().numpy(), samples).astype(np.float32)
        mean_out = occupancy_output(first, x).cpu().numpy()
    else:
        xx = x.unsqueeze(1).expand(b, k, c, h, w).reshape(b * k, c, h, w)
        out = fast(xx, sample=True, generator=generator).reshape(b, k, 2, h, w).cpu().numpy()
        samples = network_to_ternary(out)  # (B, K, H, W)
        mean_out = out.mean(axis=1)
    if fast is net:
        net.train(was_training)
    return SampleSet(samples, mean_out.astype(np.float32), network_to_ternary(mean_out), label_entropy(samples))
