"""Generates notebooks/04_training_a_completion_network.ipynb (outputs empty): .venv/bin/python notebooks/src/make04.py"""

from nbgen import code, md, save

cells = [
md("""# 04 · Training a map completion network

A robot that has seen one corner of a house can already guess a lot about the rest: rooms are rectangles,
corridors connect them, walls are straight. MCN-SLAM learns that guess from thousands of floor plans. Its
*map completion network* is a generator

$$m_s \\sim p_g(m \\mid c = m_t)$$

that takes the partial map $m_t$ the robot has built so far and returns a **sample** $m_s$ of a complete
map. Different samples are different plausible completions; where they disagree is where the network is unsure.

In this notebook you will
1. load training pairs $(m_t, m_T)$ from HouseExpo: $m_T$ the ground-truth floor plan, $m_t$ what one
   Pseudo-SLAM scan from a random start pose saw (the paper's protocol);
2. look at the paper's encodings: a ternary image and an unknown mask, the two channels of the network;
3. train a small U-net for a few minutes (`mcnkit.completion.train`) and plot its loss and validation scores;
4. draw K samples per map with `sample_completions` and look at their uncertainty;
5. load the shipped network `unet-houseexpo` and compare it with yours on the same test maps;
6. draw K whole houses per map with the shipped masked sampler, and check its calibration.

Everything runs on the CPU. With `MCNKIT_CI=1` the notebook is small (a tiny net, a few dozen pairs, seconds)."""),
code("""# Parameters: CI runs this notebook small (MCNKIT_CI=1); change them freely.
import os
from pathlib import Path

CI = os.environ.get("MCNKIT_CI") == "1"
SEED = 0
N_PAIRS = 200 if CI else 16000   # HouseExpo split to read (built once, then cached): N train + 200 val + 1000 test
N_TRAIN = 96 if CI else 4000     # training pairs used here: the first N_TRAIN of that split
N_VAL = 32 if CI else 200        # validation maps scored after every epoch
N_TEST = 16 if CI else 100       # test maps of the comparison (the first 100 are the paper's protocol)
EPOCHS = 3 if CI else 4
MAX_MINUTES = None if CI else 5.0  # training time budget (the epoch in progress is cut short)
NET = dict(base_channels=8, max_channels=32, depth=3) if CI else dict(base_channels=16, max_channels=128, depth=4)
BATCH = 16 if CI else 32
K = 4 if CI else 8               # samples per map
THREADS = 1 if CI else 2         # torch CPU threads
DATA = Path(os.environ.get("MCNKIT_DATA", "../data"))                          # `make data` installs HouseExpo here
SHARED_DATA = Path(os.environ.get("MCNKIT_SHARED_DATA", "../../shared/data"))  # used when data/ has no HouseExpo
OUT = Path("out")                # this notebook's outputs (git-ignored): out/04/, and out/cache/ in CI mode"""),
code("""import json
import time

import matplotlib.pyplot as plt
import numpy as np
import torch
from IPython.display import Markdown, display

from mcnkit.completion import complete, load_generator, sample_completions, score_maps
from mcnkit.completion.calibration import score_samples
from mcnkit.mcn import load_model
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.registry import default_weights_dir
from mcnkit.completion.train import TrainConfig, train
from mcnkit.datasets import PairSet, PairSplits, find_houseexpo, pair_stats
from mcnkit.grid import network_to_ternary, ternary_to_network
from mcnkit.viz.plots import TERNARY_CMAP
from mcnkit.types import FREE, UNKNOWN

torch.set_num_threads(THREADS)
HOUSEEXPO = find_houseexpo(DATA) or find_houseexpo(SHARED_DATA)
if HOUSEEXPO is None:
    raise FileNotFoundError(f"HouseExpo is not in {DATA.resolve()}: run `make data` "
                            "(or `mcnkit data install houseexpo --from PATH_OR_URL`)")
CACHE = (OUT / "cache" if CI else DATA / "cache") / f"houseexpo-{N_PAIRS}"
RUN = OUT / "04"
RUN.mkdir(parents=True, exist_ok=True)


def show(ax, ternary, title=""):
    \"\"\"A ternary map: free light, unknown grey, occupied black.\"\"\"
    ax.imshow(np.rint(np.asarray(ternary) * 2), cmap=TERNARY_CMAP, vmin=0, vmax=2, interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([])
    ax.set_yticks([])


t0 = time.perf_counter()
splits = load_domain_pairs("houseexpo", N_PAIRS, 200, 1000, SEED, HOUSEEXPO, CACHE, progress=True)
print(f"HouseExpo: {HOUSEEXPO}\\npairs: {len(splits.train)} train / {len(splits.val)} val / {len(splits.test)} test, "
      f"{time.perf_counter() - t0:.1f} s (cache {CACHE})")"""),
md("""## The paper's encoding
A map is a **ternary image**: occupied cells 1.0, unknown 0.5, free 0.0 (from the occupancy probability:
p > 0.5, = 0.5, < 0.5). The network sees two channels of 64 × 64: the image and an **unknown mask** (1.0
where the cell is unknown). It outputs two channels too, (image′, mask′), which go back to ternary by
*unknown if mask′ ≥ 0.5, else occupied if image′ ≥ 0.5, else free* (`mcnkit.grid`).

Each training pair is $(m_t, m_T)$: $m_T$ is the floor plan (free inside the outline, walls and the outside
occupied); $m_t$ is what HouseExpo's Pseudo-SLAM saw with one 180° scan of 2 m range from a random free
pose. Both are cropped to the plan, padded square and shrunk to 64 × 64 keeping thin walls
(`mcnkit.grid.resize_ternary`: occupied > free > unknown in each block)."""),
code("""m_t, m_T = splits.train.partial[0], splits.train.target[0]
x = ternary_to_network(m_t)   # (2, 64, 64): image, unknown mask
fig, axes = plt.subplots(1, 4, figsize=(11, 3))
show(axes[0], m_t, "m_t (ternary)")
for ax, ch, title in ((axes[1], x[0], "input channel 0: image"), (axes[2], x[1], "input channel 1: mask (1 = unknown)")):
    ax.imshow(ch, cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set_xticks([])
    ax.set_yticks([])
show(axes[3], m_T, "m_T (target)")
plt.show()
print(f"m_t: {np.mean(m_t == UNKNOWN):.0%} of the cells unknown; m_T: {np.mean(m_T == FREE):.0%} free")

# Decoding four output cells (image', mask'): -> free, occupied, unknown, free
out = np.array([[[0.2, 0.7, 0.9, 0.4]], [[0.1, 0.2, 0.6, 0.3]]], np.float32)  # (2 channels, 1 row, 4 cells)
print("network_to_ternary:", network_to_ternary(out)[0])"""),
md("""## A few training pairs
Top row $m_t$, bottom row $m_T$. One scan sees only a small part of the house: the network has to guess the
rest from the *global structure* it learned from the other maps."""),
code("""n_show = 6
fig, axes = plt.subplots(2, n_show, figsize=(1.8 * n_show, 3.8))
for j in range(n_show):
    show(axes[0, j], splits.train.partial[j], splits.train.ids[j][:8])
    show(axes[1, j], splits.train.target[j])
axes[0, 0].set_ylabel("m_t")
axes[1, 0].set_ylabel("m_T")
plt.show()
st = pair_stats(splits.train)
print(f"{st.n} training pairs: {st.free_fraction:.0%} of the cells of m_T are free; "
      f"m_t has observed {st.observed_share:.1%} of that free space (per-map mean)")"""),
md("""## Training
`mcnkit.completion.train.train(TrainConfig(...), splits)` trains the paper's (B) U-net: encoder-decoder with
skip connections, spectral normalization on every convolution, dropout in the innermost decoder levels. The loss
is the L2 distance between the two output channels and the encoding of $m_T$, with the cells that are
unknown in $m_t$ weighted more (`unknown_weight`). Pairs are augmented by the 8 symmetries of the square.

After each epoch the network's deterministic output (dropout off) is scored on the validation maps with the
paper's metric (F-measure, free space as the positive class) and the mean IoU on the cells that were unknown
in $m_t$ (the figure a trivial fill cannot game, see notebook 05); the best epoch is saved as `best`, every
epoch as `last` (resumable). The same run from a terminal is `mcnkit train --model unet --out DIR ...`."""),
code("""def subset(p, n):
    return PairSet(p.partial[:n], p.target[:n], p.ids[:n])


data = PairSplits(subset(splits.train, N_TRAIN), subset(splits.val, N_VAL), subset(splits.test, N_TEST), splits.manifest)
cfg = TrainConfig(model="unet", domain="houseexpo", out_dir=str(RUN / "run"), n_train=N_TRAIN, n_val=N_VAL,
                  n_test=N_TEST, epochs=EPOCHS, batch_size=BATCH, seed=SEED, max_minutes=MAX_MINUTES,
                  threads=THREADS, progress=True, **NET)
result = train(cfg, data)
print(f"{result.epochs_done} epochs in {result.wall_time_s:.0f} s; best validation F {result.best_val_f:.4f}, "
      f"mIoU unknown {result.best_val_miou:.4f}; checkpoint {result.best_path}")"""),
md("""## Loss and validation
Left: the training loss per epoch. Right: the validation scores per epoch against wall time, next to the
history of the shipped network's own training run (dashed, from its checkpoint; in full mode the same 200
validation maps) and the scores of the trivial fill "every unknown cell is free" (dotted). A network that is
not above the dotted mIoU line has learned nothing yet about the unseen part of the house."""),
code("""WEIGHTS = default_weights_dir()
shipped, shipped_info = load_generator(WEIGHTS / "unet-houseexpo")
hist = result.history
ep = [h["epoch"] + 1 for h in hist]
fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
axes[0].plot(ep, [h["train_loss"] for h in hist], "o-")
axes[0].set_xticks(ep)
axes[0].set_xlabel("epoch")
axes[0].set_ylabel("weighted L2 loss")
axes[0].set_title("training loss")
wall = [h["wall_time_s"] / 60 for h in hist]
axes[1].plot(wall, [h["val_f"] for h in hist], "o-", color="C0", label="ours: F (free)")
axes[1].plot(wall, [h["val_miou"] for h in hist], "o-", color="C1", label="ours: mIoU unknown")
sh = shipped_info.get("history", [])
if sh:
    sw = [h["wall_time_s"] / 60 for h in sh]
    axes[1].plot(sw, [h["val_f"] for h in sh], "--", color="C0", alpha=0.6, label="shipped run: F")
    axes[1].plot(sw, [h["val_miou"] for h in sh], "--", color="C1", alpha=0.6, label="shipped run: mIoU")
fill = score_maps(np.where(data.val.partial == UNKNOWN, FREE, data.val.partial), data.val.target, data.val.partial)
axes[1].axhline(fill.f_measure, color="C0", ls=":", lw=1, label="all-free fill: F")
axes[1].axhline(fill.miou_unknown, color="C1", ls=":", lw=1, label="all-free fill: mIoU")
axes[1].set_xlabel("wall time (min)")
axes[1].set_title(f"validation ({N_VAL} maps)")
axes[1].legend(fontsize=8)
fig.tight_layout()
fig.savefig(RUN / "training.png", dpi=100)
plt.show()"""),
md("""## Sampling: $m_s \\sim p_g(m \\mid m_t)$
A U-net is deterministic; the paper nevertheless treats completion as sampling. Here sampling is real:
`sample_completions` keeps **dropout on** at inference (as pix2pix does) and draws K completions per map in
one batch, from a seeded `torch.Generator`. It returns the K ternary samples, the mean output, and a per-cell
**uncertainty**: the entropy of the K sampled labels divided by log 3 (0 where all samples agree, 1 where the
labels are spread evenly). `diversity` is the share of cells on which two samples differ."""),
code("""ours, _ = load_generator(result.best_path)
rows = np.linspace(0, N_TEST - 1, 3).astype(int)


def sample_figure(net, name):
    s = sample_completions(net, data.test.partial[rows], K, torch.Generator().manual_seed(SEED))
    cols = K + 4
    fig, axes = plt.subplots(len(rows), cols, figsize=(1.35 * cols, 1.45 * len(rows)), squeeze=False)
    for r, i in enumerate(rows):
        show(axes[r, 0], data.test.partial[i], "m_t")
        for j in range(K):
            show(axes[r, 1 + j], s.samples[r, j], f"sample {j + 1}")
        show(axes[r, K + 1], s.mean[r], "mean output")
        axes[r, K + 2].imshow(s.uncertainty[r], cmap="magma", vmin=0, vmax=1, interpolation="nearest")
        axes[r, K + 2].set_title("uncertainty", fontsize=8)
        axes[r, K + 2].set_xticks([])
        axes[r, K + 2].set_yticks([])
        show(axes[r, K + 3], data.test.target[i], "m_T")
    fig.suptitle(f"{name}: {K} samples per map (dropout on)", fontsize=10)
    fig.tight_layout()
    fig.savefig(RUN / f"samples_{name.split()[0]}.png", dpi=100)
    plt.show()
    print(f"{name}: diversity {s.diversity.mean():.4f} (share of cells two samples differ on), "
          f"mean uncertainty on cells unknown in m_t {s.uncertainty[data.test.partial[rows] == UNKNOWN].mean():.3f}")


sample_figure(ours, "ours (just trained)")"""),
md("""## The shipped network
`mcnkit/weights/unet-houseexpo` was trained with the same code for longer and on more pairs, with a weight
average (EMA) and flip-only augmentation (HouseExpo plans are not symmetric under transposition once padded to
a square); the cell below prints its size next to ours. Its model card (`unet-houseexpo.md`) says how it was
trained; its metrics, as measured when it was shipped, are in `unet-houseexpo.metrics.json` — read here, not
copied into this text."""),
code("""card = json.loads((WEIGHTS / "unet-houseexpo.metrics.json").read_text())
tc = shipped_info.get("train_config", {})
print(f"shipped unet-houseexpo: {sum(p.numel() for p in shipped.parameters()):,} parameters "
      f"(ours: {sum(p.numel() for p in ours.parameters()):,}); trained on {tc.get('n_train', '?')} pairs, "
      f"{len(shipped_info.get('history', []))} epochs, {shipped_info.get('run_wall_time_s', float('nan')) / 60:.1f} min")
lines = ["| set, positive class | n | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) |", "|---|---|---|---|---|---|---|"]
lines += [f"| {k} | {m['n_maps']} | {m['accuracy']:.4f} | {m['precision']:.4f} | {m['recall']:.4f} | "
          f"{m['f_measure']:.4f} ± {m['f_ci95']:.4f} | {m['miou_unknown']:.4f} ± {m['miou_ci95']:.4f} |"
          for k, m in card.items()]
display(Markdown("\\n".join(lines)))"""),
md("""## Ours against the shipped network, on the same test maps
Scores with free space as the positive class (per-map mean ± 95 % CI), with two references that need no
network: the partial map itself (unknown stays unknown) and the trivial fill "every unknown cell is free"."""),
code("""test = data.test
fill_free = np.where(test.partial == UNKNOWN, FREE, test.partial).astype(np.float32)
preds = {
    "(C) partial map m_t": test.partial,
    "unknown filled all-free": fill_free,
    f"ours ({result.epochs_done} epochs on {N_TRAIN} pairs)": complete(ours, test.partial),
    "shipped unet-houseexpo": complete(shipped, test.partial),
}
lines = [f"| method ({N_TEST} test maps) | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) |", "|---|---|---|---|---|---|"]
scores = {}
for name, pred in preds.items():
    s = scores[name] = score_maps(pred, test.target, test.partial, "free")
    lines.append(f"| {name} | {s.accuracy:.4f} | {s.precision:.4f} | {s.recall:.4f} | {s.f_measure:.4f} ± {s.f_ci95:.4f} | "
                 f"{s.miou_unknown:.4f} ± {s.miou_ci95:.4f} |")
display(Markdown("\\n".join(lines)))
same = [k for k, m in card.items() if k.startswith("test") and k.endswith("free") and m["n_maps"] == N_TEST]
if same:  # full mode: the first 100 test maps are the card's "paper protocol" set
    s = scores["shipped unet-houseexpo"]
    print(f"card '{same[0]}': F {card[same[0]]['f_measure']:.4f}, mIoU {card[same[0]]['miou_unknown']:.4f}; "
          f"measured here: F {s.f_measure:.4f}, mIoU {s.miou_unknown:.4f}")"""),
code("""sample_figure(shipped, "shipped unet-houseexpo")"""),
md("""## The masked sampler: K different houses
Dropout on a deterministic U-net gives near copies of one completion: the uncertainty panels above are almost
black. The shipped **masked sampler** (`load_model("sampler")`, `mcnkit.completion.masked`) is trained to predict
$m_T$'s labels from $m_t$ *plus a random share of $m_T$'s cells already revealed*. To draw a sample it fills the
unknown cells round by round: a few scattered cells first (they decide where the house ends and where the rooms
are), each later round conditioned on every label drawn before, so walls continue, rooms close and doors appear.
Cells that $m_t$ observed are never changed. Each of the K samples below is a different, whole house."""),
code("""sampler = load_model("sampler")
s = sample_completions(sampler, test.partial[rows], K, torch.Generator().manual_seed(SEED))
cols = K + 3
fig, axes = plt.subplots(len(rows), cols, figsize=(1.35 * cols, 1.45 * len(rows)), squeeze=False)
for r, i in enumerate(rows):
    show(axes[r, 0], test.partial[i], "m_t")
    for j in range(K):
        show(axes[r, 1 + j], s.samples[r, j], f"sample {j + 1}")
    axes[r, K + 1].imshow(s.uncertainty[r], cmap="magma", vmin=0, vmax=1, interpolation="nearest")
    axes[r, K + 1].set_title("uncertainty", fontsize=8)
    axes[r, K + 1].set_xticks([])
    axes[r, K + 1].set_yticks([])
    show(axes[r, K + 2], test.target[i], "m_T")
fig.suptitle(f"sampler: {K} samples per map", fontsize=10)
fig.tight_layout()
fig.savefig(RUN / "samples_sampler.png", dpi=100)
plt.show()
print(f"sampler: diversity {s.diversity.mean():.4f} (share of cells two samples differ on)")"""),
md("""## How often is a cell free? Per-cell frequency and calibration
Over many samples, the share of samples in which a cell is free is the sampler's probability that it is free.
A calibrated sampler is right as often as it says: of the cells it calls free 70 % of the time, 70 % are free in
$m_T$. The reliability diagram bins the unknown cells of every test map by that share and plots how often they
are truly free; ECE is the mean gap, weighted by the cells in each bin. `score_samples` also says whether the
samples look like houses: their free space in one region, and their boundary roughness against the true maps'."""),
code("""K_FREQ = 16 if CI else 32
many = np.concatenate([sample_completions(sampler, test.partial[i:i + 50], K_FREQ,
                                          torch.Generator().manual_seed(SEED)).samples
                       for i in range(0, len(test), 50)])
freq = (many == FREE).mean(axis=1)  # (N, H, W): the share of samples that say free
sc = score_samples(many, test.partial, test.target, first=min(8, K_FREQ))
fig, axes = plt.subplots(1, 3, figsize=(11, 3.6))
show(axes[0], test.partial[rows[0]], "m_t")
im = axes[1].imshow(freq[rows[0]], cmap="viridis", vmin=0, vmax=1, interpolation="nearest")
axes[1].set_title(f"free in how many of {K_FREQ} samples", fontsize=8)
axes[1].set_xticks([])
axes[1].set_yticks([])
fig.colorbar(im, ax=axes[1], fraction=0.046)
table = sc.reliability
filled = table[:, 2] > 0
axes[2].plot([0, 1], [0, 1], color="0.6", ls="--", lw=1, label="calibrated")
axes[2].plot(table[filled, 0], table[filled, 1], "o-", label=f"sampler (ECE {sc.ece:.3f})")
axes[2].set(xlabel="free in this share of the samples", ylabel="truly free", xlim=(0, 1), ylim=(0, 1),
            title=f"reliability, {len(test)} test maps")
axes[2].legend(fontsize=8)
fig.tight_layout()
fig.savefig(RUN / "reliability.png", dpi=100)
plt.show()
print(sc.summary())"""),
md("""Compare the two sample figures and the diversity printed under each: the uncertainty map shows the cells
on which the K samples disagree — where the completed house ends, where a wall or a door may be. Those
disagreements are what MCN-SLAM uses later: each particle completes its own map, and where the samples differ
is where the robot should look next.

Try it yourself: change `N_TRAIN`, `EPOCHS` or `NET` in the parameters cell and run again. To train the
shipped network from a terminal (its card has the exact command):"""),
code("""print(shipped_info.get("reproduce", "see mcnkit/weights/unet-houseexpo.md"))"""),
]
save(cells, "04_training_a_completion_network.ipynb")
