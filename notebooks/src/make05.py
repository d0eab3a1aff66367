"""Generates notebooks/05_experiment_1.ipynb (outputs empty): .venv/bin/python notebooks/src/make05.py"""

from nbgen import code, md, save

cells = [
md("""# 05 · Experiment 1: map completion from one scan

The paper's first experiment asks how well a completion network fills in a house from what a robot sees in
its **first scan**. For each HouseExpo test map, $m_T$ is the floor plan and $m_t$ the Pseudo-SLAM map after one
180° scan of 2 m range (64 × 64 cells, notebook 04). Every method produces a completed map, and every cell is
scored as a binary classification against $m_T$: accuracy, precision, recall and F-measure.

The rows of the table (`mcnkit.experiments.exp1`, the same as `mcnkit experiment exp1`):

| row | what it is |
|---|---|
| (A) pix2pix, (B) U-net | the shipped networks trained on HouseExpo (deterministic output: dropout off) |
| (B) U-net trained on procedural | our stand-in for the paper's HOME'S domain: the prior depends on where it was learned |
| (B′) small U-net | the fast network the particle filter uses (one completion per particle) |
| (C) partial map | $m_t$ itself, no completion |
| (D) retrieval | the training map that agrees best with what $m_t$ observed, with $m_t$ pasted over it |
| unknown filled all-free / all-occupied | sanity rows: a trivial fill of every unknown cell |

Each method is also run on the second test domain (procedural apartments with HOME'S-style masking:
10–50 % of the map hidden). With `MCNKIT_CI=1` the notebook runs on 10 maps; in full mode on the paper's 100
and then on 1000."""),
code("""# Parameters: CI runs this notebook small (MCNKIT_CI=1); change them freely.
import os
from pathlib import Path

CI = os.environ.get("MCNKIT_CI") == "1"
SEED = 0
N_TEST = 10 if CI else 100            # HouseExpo test maps (the paper's protocol: the first 100)
N_TEST_LARGE = None if CI else 1000   # a second run on more test maps (up to 1000); None skips it
N_TRAIN = 200 if CI else 16000        # HouseExpo split to read (cached): its training maps are the bank of (D)
N_PROC_TRAIN = 200 if CI else 4000    # procedural domain: the bank of (D)
N_PROC_TEST = 10 if CI else 100       # procedural test maps
N_SAMPLES = 4                         # samples per map in the example figure
THREADS = 1 if CI else 2              # torch CPU threads
DATA = Path(os.environ.get("MCNKIT_DATA", "../data"))                          # `make data` installs HouseExpo here
SHARED_DATA = Path(os.environ.get("MCNKIT_SHARED_DATA", "../../shared/data"))  # used when data/ has no HouseExpo
OUT = Path("out")                     # this notebook's outputs (git-ignored): out/05/, and out/cache/ in CI mode"""),
code("""import csv
import time

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, Markdown, display

from mcnkit.datasets import find_houseexpo
from mcnkit.experiments import Exp1Config, paper, run_exp1

HOUSEEXPO = find_houseexpo(DATA) or find_houseexpo(SHARED_DATA)
if HOUSEEXPO is None:
    raise FileNotFoundError(f"HouseExpo is not in {DATA.resolve()}: run `make data` "
                            "(or `mcnkit data install houseexpo --from PATH_OR_URL`)")
CACHE = (OUT / "cache" if CI else DATA / "cache") / f"houseexpo-{N_TRAIN}"
TEXT_COLUMNS = {"method", "train_domain", "test_domain", "positive_class"}


def exp1(n_test):
    \"\"\"Runs Experiment 1 on the first n_test HouseExpo test maps; returns (output dir, Markdown report, CSV rows).\"\"\"
    out = OUT / "05" / f"exp1-{n_test}"
    cfg = Exp1Config(out_dir=str(out), n_test=n_test, n_train=N_TRAIN, n_procedural_train=N_PROC_TRAIN,
                     n_procedural_test=N_PROC_TEST, n_samples=N_SAMPLES, seed=SEED, houseexpo=str(HOUSEEXPO),
                     cache_dir=str(CACHE), threads=THREADS)
    t0 = time.perf_counter()
    report = run_exp1(cfg)
    with open(out / "exp1.csv", newline="") as fh:
        rows = [{k: v if k in TEXT_COLUMNS else float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    print(f"Experiment 1 on {n_test} HouseExpo test maps: {time.perf_counter() - t0:.0f} s; "
          f"{out}/exp1.csv, exp1.md, exp1_examples.png")
    return out, report, rows


out, report, rows = exp1(N_TEST)"""),
md("""## The report
`run_exp1` writes `exp1.csv` (one row per method × train domain × test domain × positive class),
`exp1.md` (below) and an example figure. The scores are per-map means with a 95 % confidence half-width
(1.96 · sd / √n) and the pooled figures (counts summed over all maps). The paper's table is printed under
ours for comparison."""),
code("""display(Markdown(report))"""),
md("""## Examples
Rows are test maps; the columns are $m_t$, then for pix2pix and for the U-net `N_SAMPLES` samples
$m_s \\sim p_g(m \\mid m_t)$ (dropout on) and the per-cell uncertainty (entropy of the sampled labels), then $m_T$."""),
code("""display(Image(filename=str(out / "exp1_examples.png")))"""),
md("""## F and mIoU per row
Free space is the positive class (the paper's reading, below). Blue: F-measure; orange: mean IoU on the cells
that were unknown in $m_t$; whiskers: 95 % CI. Black ticks: the F-measure the paper reports for the
corresponding row (HouseExpo test; the paper's cross-domain row was trained on HOME'S, ours on procedural
apartments)."""),
code("""PAPER_ROWS = {r.method: [r.accuracy, r.precision, r.recall, r.f_measure] for r in paper.EXP1}  # the paper's table
OURS_TO_PAPER = {("(A) pix2pix", "houseexpo"): "(A) pix2pix", ("(B) U-net", "houseexpo"): "(B) U-net",
                 ("(B) U-net", "procedural"): "(B) U-net trained on HOME'S", ("(C) partial map", "-"): "(C) Pseudo SLAM",
                 ("(D) retrieval", "houseexpo"): "(D) training map with highest precision"}


def bar_chart(rows, path):
    fig, axes = plt.subplots(1, 2, figsize=(13, 5), sharex=True)
    for ax, dom in zip(axes, ("houseexpo", "procedural"), strict=True):
        rs = [r for r in rows if r["test_domain"] == dom and r["positive_class"] == "free"]
        labels = [f"{r['method']} (trained: {r['train_domain']})" if r["method"].startswith(("(A)", "(B)"))
                  else r["method"] for r in rs]
        y = np.arange(len(rs))
        ax.barh(y - 0.2, [r["f_measure"] for r in rs], 0.4, xerr=[r["f_ci95"] for r in rs], color="C0",
                label="F (free positive)")
        ax.barh(y + 0.2, [r["miou_unknown"] for r in rs], 0.4, xerr=[r["miou_ci95"] for r in rs], color="C1",
                label="mIoU on unknown cells")
        if dom == "houseexpo":
            for k, r in enumerate(rs):
                paper = OURS_TO_PAPER.get((r["method"], r["train_domain"]))
                if paper:
                    ax.plot(PAPER_ROWS[paper][3], k - 0.2, "k|", ms=16, mew=2.5)
            ax.plot([], [], "k|", ms=10, mew=2.5, label="paper's F")
        ax.set_yticks(y, labels, fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.grid(axis="x", alpha=0.3)
        ax.set_title(f"test: {dom} ({int(rs[0]['n_maps'])} maps)", fontsize=10)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    display(Image(filename=str(path)))  # not plt.show(): run_exp1 has switched matplotlib to its Agg backend


bar_chart(rows, out / "exp1_bars.png")"""),
md("""## Which class is "positive"? The free-class reading
The paper says the positive class is "the occupancy area that represents the shape of the room". Its own row
(C), the partial map with no completion, tells which class that is: a single scan observes a *little* free space,
nearly all of it correctly, and hardly any wall. Reading the confusion matrix backwards also gives the share
of positive cells in $m_T$ that the paper's (C) numbers imply:
Acc = 1 − P · (1 + Rec / Prec − 2 · Rec), so P = (1 − Acc) / (1 + Rec / Prec − 2 · Rec)."""),
code("""def implied_share(acc, prec, rec):
    return (1 - acc) / (1 + rec / prec - 2 * rec) if prec > 0 else float("nan")


paper_c = PAPER_ROWS["(C) Pseudo SLAM"]
ours_c = {r["positive_class"]: r for r in rows if r["method"] == "(C) partial map" and r["test_domain"] == "houseexpo"}
lines = ["| (C) partial map | Acc | Prec | Rec | F | implied positive share of m_T |", "|---|---|---|---|---|---|",
         f"| the paper | {paper_c[0]:.4f} | {paper_c[1]:.4f} | {paper_c[2]:.4f} | {paper_c[3]:.4f} | "
         f"{implied_share(*paper_c[:3]):.0%} |"]
for cls, r in ours_c.items():
    lines.append(f"| ours, positive = {cls} | {r['accuracy']:.4f} | {r['precision']:.4f} | {r['recall']:.4f} | "
                 f"{r['f_measure']:.4f} | {implied_share(r['accuracy'], r['precision'], r['recall']):.0%} |")
display(Markdown("\\n".join(lines)))


def log_gap(ours, paper):  # how many e-folds apart two positive scores are
    return abs(np.log(max(ours, 1e-9) / paper))


closest = min(ours_c, key=lambda c: log_gap(ours_c[c]["recall"], paper_c[2]) + log_gap(ours_c[c]["f_measure"], paper_c[3]))
print(f"recall and F of row (C) are closest to the paper's with the reading 'positive = {closest}'")"""),
md("""With free space positive, our row (C) has the paper's shape: high precision (what one scan calls free is
free), tiny recall (it sees a few percent of the house), hence a tiny F. With the occupied class positive the
recall collapses to almost nothing, which is not what the paper measured. So the table's positive class is the
**free space inside the house**; `exp1.md` reports the occupied class too.

## Why mIoU on the unknown cells is the figure to watch
With free space positive, the F-measure rewards predicting *free* everywhere: the trivial fill "every unknown
cell is free" gets recall 1 and precision equal to the share of free cells, so its F is high without
knowing anything about houses. The **mean IoU over {free, occupied} on the cells that were unknown in
$m_t$** looks only at the cells a method had to guess, and asks for both classes: the all-free fill gets the
IoU of the free class there (about the share of free cells among them) and 0 for the occupied class, so
about half of that share at most; the partial map gets 0. A method scores there only by putting walls and
rooms where they really are."""),
code("""he = {(r["method"], r["train_domain"]): r for r in rows if r["test_domain"] == "houseexpo" and r["positive_class"] == "free"}
fill, unet = he[("unknown filled all-free", "-")], he.get(("(B) U-net", "houseexpo"))
print(f"HouseExpo, {int(fill['n_maps'])} test maps, free space positive:")
print(f"  all-free fill:  F {fill['f_measure']:.3f} (recall {fill['recall']:.3f}), mIoU unknown {fill['miou_unknown']:.3f}")
if unet:
    print(f"  (B) U-net:      F {unet['f_measure']:.3f} (recall {unet['recall']:.3f}), mIoU unknown {unet['miou_unknown']:.3f}")
print(f"  the paper's (B) U-net: F {PAPER_ROWS['(B) U-net'][3]:.3f} (mIoU not reported)")
beat = [f"{m} [{d}]" for (m, d), r in he.items() if r["miou_unknown"] - r["miou_ci95"] > fill["miou_unknown"] + fill["miou_ci95"]]
print("rows whose mIoU is above the all-free fill's (95 % CIs apart):", ", ".join(beat) or "none")"""),
md("""## More test maps
100 maps leave confidence intervals of a few points. The full mode runs the experiment again on the first
`N_TEST_LARGE` test maps (the first 100 are the same maps as above)."""),
code("""if N_TEST_LARGE:
    out_l, report_l, rows_l = exp1(N_TEST_LARGE)
    small = {(r["method"], r["train_domain"]): r for r in rows if r["test_domain"] == "houseexpo" and r["positive_class"] == "free"}
    lines = [f"| method | train | F, {N_TEST} maps | F, {N_TEST_LARGE} maps | mIoU, {N_TEST} maps | mIoU, {N_TEST_LARGE} maps |",
             "|---|---|---|---|---|---|"]
    for r in rows_l:
        if r["test_domain"] == "houseexpo" and r["positive_class"] == "free":
            s = small[(r["method"], r["train_domain"])]
            lines.append(f"| {r['method']} | {r['train_domain']} | {s['f_measure']:.4f} ± {s['f_ci95']:.4f} | "
                         f"{r['f_measure']:.4f} ± {r['f_ci95']:.4f} | {s['miou_unknown']:.4f} ± {s['miou_ci95']:.4f} | "
                         f"{r['miou_unknown']:.4f} ± {r['miou_ci95']:.4f} |")
    display(Markdown("\\n".join(lines)))
    bar_chart(rows_l, out_l / "exp1_bars.png")
else:
    print("N_TEST_LARGE is None: skipped (set it to 1000 in the parameters cell)")"""),
md("""From a terminal, the same experiment (outputs `exp1.csv`, `exp1.md`, `exp1_examples.png`):

```bash
mcnkit experiment exp1 --out results/exp1 --n-test 100
mcnkit experiment exp1 --out results/exp1-1000 --n-test 1000
```"""),
]
save(cells, "05_experiment_1.ipynb")
