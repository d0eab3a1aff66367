"""HouseExpo floor plans: stream them from the upstream archive, validate them, rasterize them.

HouseExpo (T. Li et al. 2019, MIT licence) ships 35,126 plans as ``json/<id>.json`` in ``json.tar.gz``.  Each
plan holds ONE closed outline polygon ``verts`` (metres) of the free space; everything outside it is wall or
exterior.  This module

* streams plans from the archive (``tarfile`` in stream mode, nothing unpacked to disk) or from an extracted
  ``json/`` folder (:func:`iter_plans`), skipping malformed JSON, empty/degenerate or self-intersecting
  outlines, unknown ids and a corrupted archive tail with a reason each (:class:`SkipLog`) -- never a crash;
* rasterizes any plan at any resolution, vectorised (:func:`rasterize_plan`): a cell is free iff its centre
  lies inside the outline (even-odd rule), walls and exterior are occupied, like HouseExpo's own renderer;
* installs the archive into ``data/`` or ``$MCNKIT_DATA`` from a path, ``file://`` or ``http(s)://`` URL,
  checking its sha256 (:func:`install_houseexpo`).

Example:
    >>> plan = FloorPlan("square", np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    >>> free, grid = rasterize_plan(plan, resolution_m=0.25, border_cells=1)
    >>> int(free.sum()), grid.shape
    (16, (6, 6))
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tarfile
import tempfile
import urllib.parse
import urllib.request
import zlib
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray

from mcnkit.locations import data_dir, shared_data_dir
from mcnkit.types import GridSpec

__all__ = [
    "HOUSEEXPO_SHA256",
    "FloorPlan",
    "PlanError",
    "SkipLog",
    "default_data_dir",
    "find_houseexpo",
    "install_houseexpo",
    "is_self_intersecting",
    "iter_plans",
    "load_plan",
    "parse_plan",
    "polygon_area_m2",
    "rasterize_plan",
    "rasterize_polygon",
    "read_split",
    "sha256_of",
]

F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

# sha256 of the upstream HouseExpo/json.tar.gz (33,717 plans) as kept in ../shared/data/houseexpo.
HOUSEEXPO_SHA256 = "5965a610a9e8931b6f82860a91728f9257cbd68b10710e18b1d0941ba1a742ec"


class PlanError(ValueError):
    """A plan that cannot be used; the message is the reason recorded in a :class:`SkipLog`."""


@dataclass(frozen=True)
class FloorPlan:
    """A floor plan: the free-space outline ``verts_m`` (N, 2) in metres, plus optional room boxes.

    ``room_boxes_m`` (R, 4) holds axis-aligned ``[x1, y1, x2, y2]`` room boxes with labels ``room_labels``.
    """

    id: str
    verts_m: F64
    room_boxes_m: F64 = field(default_factory=lambda: np.zeros((0, 4)))
    room_labels: tuple[str, ...] = ()

    @property
    def bbox_m(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)`` of the outline."""
        lo, hi = self.verts_m.min(axis=0), self.verts_m.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def area_m2(self) -> float:
        """Area enclosed by the outline (shoelace formula)."""
        return polygon_area_m2(self.verts_m)


@dataclass
class SkipLog:
    """Plans skipped while reading or building, with one reason each."""

    reasons: dict[str, str] = field(default_factory=dict)

    def add(self, key: str, reason: str) -> None:
        """Records that ``key`` (a plan id or member name) was skipped because of ``reason``."""
        self.reasons[key] = reason

    @property
    def count(self) -> int:
        """How many were skipped."""
        return len(self.reasons)

    def summary(self) -> dict[str, int]:
        """Counts per reason kind (the text before the first ':')."""
        return dict(Counter(r.split(":")[0] for r in self.reasons.values()))


def polygon_area_m2(verts_m: NDArray[np.floating]) -> float:
    """Unsigned area of a simple polygon (N, 2) by the shoelace formula."""
    x, y = verts_m[:, 0], verts_m[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2.0)


def _orient(ax: F64, ay: F64, bx: F64, by: F64, cx: F64, cy: F64) -> F64:
    return np.sign((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))


def is_self_intersecting(verts_m: NDArray[np.floating], chunk: int = 512) -> bool:
    """True if two non-adjacent edges of the closed polygon properly cross (strictly, not just touch).

    All edge pairs are tested with orientation signs, in chunks of ``chunk`` edges (vectorised).
    """
    p = np.asarray(verts_m, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    n = len(p)
    if n < 4:
        return False
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    j = np.arange(n)
    for start in range(0, n, chunk):
        i = np.arange(start, min(start + chunk, n))[:, None]
        # Candidate pairs: i < j, not adjacent, bounding boxes overlap.
        cand = (j[None, :] > i + 1) & ~((i == 0) & (j[None, :] == n - 1))
        cand &= (lo[i, 0] <= hi[None, :, 0]) & (lo[None, :, 0] <= hi[i, 0])
        cand &= (lo[i, 1] <= hi[None, :, 1]) & (lo[None, :, 1] <= hi[i, 1])
        ii, jj = np.nonzero(cand)
        if ii.size == 0:
            continue
        ii = ii + start
        a, b, c, d = p[ii], q[ii], p[jj], q[jj]
        o1 = _orient(a[:, 0], a[:, 1], b[:, 0], b[:, 1], c[:, 0], c[:, 1])
        o2 = _orient(a[:, 0], a[:, 1], b[:, 0], b[:, 1], d[:, 0], d[:, 1])
        o3 = _orient(c[:, 0], c[:, 1], d[:, 0], d[:, 1], a[:, 0], a[:, 1])
        o4 = _orient(c[:, 0], c[:, 1], d[:, 0], d[:, 1], b[:, 0], b[:, 1])
        if np.any((o1 * o2 < 0) & (o3 * o4 < 0)):
            return True
    return False


def parse_plan(text: str | bytes, expected_id: str | None = None, check_crossings: bool = True) -> FloorPlan:
    """Parses one HouseExpo JSON document into a validated :class:`FloorPlan`.

    Raises:
        PlanError: malformed JSON, missing/invalid ``verts``, fewer than 3 distinct vertices, zero area,
            an id that does not match ``expected_id``, or (with ``check_crossings``) a self-intersecting outline.
    """
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PlanError(f"malformed json: {exc}") from None
    if not isinstance(doc, dict) or "verts" not in doc:
        raise PlanError("malformed json: no 'verts'")
    plan_id = str(doc.get("id", expected_id or ""))
    if expected_id is not None and plan_id != expected_id:
        raise PlanError(f"id mismatch: file {expected_id} holds id {plan_id}")
    try:
        verts = np.asarray(doc["verts"], dtype=np.float64)
    except (TypeError, ValueError):
        raise PlanError("malformed json: 'verts' is not a list of [x, y]") from None
    if verts.ndim != 2 or verts.shape[1] != 2 or not np.all(np.isfinite(verts)):
        raise PlanError(f"bad outline: verts of shape {verts.shape}")
    if len(verts) > 1 and np.array_equal(verts[0], verts[-1]):
        verts = verts[:-1]  # explicitly closed ring
    keep = np.any(verts != np.roll(verts, 1, axis=0), axis=1) if len(verts) > 1 else np.ones(len(verts), bool)
    verts = verts[keep]  # drop repeated consecutive vertices
    if len(verts) < 3:
        raise PlanError(f"empty outline: {len(verts)} distinct vertices")
    if polygon_area_m2(verts) <= 1e-9:
        raise PlanError("empty outline: zero area")
    if check_crossings and is_self_intersecting(verts):
        raise PlanError("self-intersecting outline")
    boxes: list[list[float]] = []
    labels: list[str] = []
    rooms = doc.get("room_category", {})
    if isinstance(rooms, dict):
        for label, rects in rooms.items():
            for r in rects if isinstance(rects, list) else []:
                if isinstance(r, list) and len(r) == 4:
                    boxes.append([float(v) for v in r])
                    labels.append(str(label))
    box_arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return FloorPlan(plan_id, verts, box_arr, tuple(labels))


def _member_id(name: str) -> str | None:
    base = name.rsplit("/", 1)[-1]
    return base[: -len(".json")] if base.endswith(".json") else None


def iter_plans(
    source: str | os.PathLike[str],
    ids: Iterable[str] | None = None,
    skips: SkipLog | None = None,
    check_crossings: bool = True,
) -> Iterator[FloorPlan]:
    """Yields valid plans from ``json.tar.gz`` (streamed) or an extracted folder (``json/`` or its parent).

    With ``ids``, only those plans are read (in archive order) and ids absent from the source are recorded in
    ``skips`` as ``unknown id``.  Bad plans and a corrupted archive tail are recorded and skipped.
    """
    skips = skips if skips is not None else SkipLog()
    wanted = None if ids is None else set(ids)
    seen: set[str] = set()
    path = Path(source)
    if path.is_dir():
        folder = path / "json" if (path / "json").is_dir() else path
        names = sorted(folder.glob("*.json")) if wanted is None else [folder / f"{i}.json" for i in sorted(wanted)]
        for f in names:
            if not f.is_file():
                continue
            seen.add(f.stem)
            try:
                yield parse_plan(f.read_bytes(), f.stem, check_crossings)
            except (PlanError, OSError) as exc:
                skips.add(f.stem, str(exc))
    else:
        try:
            with tarfile.open(path, "r|gz") as tf:
                for member in tf:
                    pid = _member_id(member.name)
                    if pid is None or not member.isfile() or (wanted is not None and pid not in wanted):
                        continue
                    seen.add(pid)
                    fh = tf.extractfile(member)
                    try:
                        yield parse_plan(fh.read() if fh else b"", pid, check_crossings)
                    except PlanError as exc:
                        skips.add(pid, str(exc))
                    if wanted is not None and len(seen) == len(wanted):
                        break
        except (tarfile.TarError, EOFError, OSError, zlib.error) as exc:
            skips.add(f"archive:{path.name}", f"corrupted archive: {type(exc).__name__}: {exc}")
    for missing in sorted((wanted or set()) - seen):
        skips.add(missing, "unknown id: not in the source")


def load_plan(source: str | os.PathLike[str], plan_id: str) -> FloorPlan:
    """Reads one plan by id; raises :class:`PlanError` with the reason when it is missing or invalid."""
    skips = SkipLog()
    for plan in iter_plans(source, [plan_id], skips):
        return plan
    raise PlanError(f"houseexpo:{plan_id}: {next(iter(skips.reasons.values()), 'not found')}")


def read_split(path: str | os.PathLike[str]) -> list[str]:
    """Reads an official split file (one 32-hex id per line, blank lines ignored)."""
    return [s.strip() for s in Path(path).read_text().splitlines() if s.strip()]


def rasterize_polygon(verts_m: NDArray[np.floating], grid: GridSpec) -> BoolArray:
    """Cells of ``grid`` whose centre lies inside the polygon (even-odd rule), shape (height, width), vectorised.

    Scanline fill: every edge is intersected with every row's centre line; each crossing toggles the inside
    state from the first cell centre right of it, and a cumulative XOR along the row fills the spans.
    """
    p = np.asarray(verts_m, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    res = grid.resolution_m
    yc = grid.origin_y_m + (np.arange(grid.height) + 0.5) * res  # (H,)
    y0, y1 = p[:, 1][:, None], q[:, 1][:, None]  # (E, 1)
    # Half-open rule: an edge covers rows with min(y0, y1) <= yc < max(y0, y1) (horizontal edges none).
    crosses = (np.minimum(y0, y1) <= yc[None, :]) & (yc[None, :] < np.maximum(y0, y1))  # (E, H)
    e, r = np.nonzero(crosses)
    t = (yc[r] - p[e, 1]) / (q[e, 1] - p[e, 1])
    x = p[e, 0] + t * (q[e, 0] - p[e, 0])
    # First column whose centre is strictly right of x: origin + (c + 0.5) res > x.
    col = np.floor((x - grid.origin_x_m) / res - 0.5).astype(np.int64) + 1
    col = np.clip(col, 0, grid.width)
    toggles = np.zeros((grid.height, grid.width + 1), dtype=np.int64)
    np.add.at(toggles, (r, col), 1)
    return (np.cumsum(toggles[:, : grid.width], axis=1) % 2).astype(bool)


def rasterize_plan(
    plan: FloorPlan, resolution_m: float = 1.0 / 16.0, border_cells: int = 35
) -> tuple[BoolArray, GridSpec]:
    """Rasterizes a plan: ``free`` (H, W) bool (True inside the outline) and its :class:`GridSpec`.

    The grid spans the outline's bounding box plus ``border_cells`` cells of occupied exterior on every side
    (HouseExpo's pseudo-SLAM uses a 25-pixel render border plus 10 pixels of padding = 35).  Row 0 is the
    lowest ``y``, as in HouseExpo's images (whose row index grows with ``y``).
    """
    min_x, min_y, max_x, max_y = plan.bbox_m
    width = int(np.ceil((max_x - min_x) / resolution_m - 1e-9)) + 2 * border_cells
    height = int(np.ceil((max_y - min_y) / resolution_m - 1e-9)) + 2 * border_cells
    grid = GridSpec(
        resolution_m,
        min_x - border_cells * resolution_m,
        min_y - border_cells * resolution_m,
        max(width, 1),
        max(height, 1),
    )
    return rasterize_polygon(plan.verts_m, grid), grid


def sha256_of(path: str | os.PathLike[str]) -> str:
    """sha256 hex digest of a file; of a folder, over its sorted ``*.json`` names, sizes and mtimes."""
    h = hashlib.sha256()
    p = Path(path)
    if p.is_dir():
        for f in sorted(p.rglob("*.json")):
            st = f.stat()
            h.update(f"{f.relative_to(p)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
        return h.hexdigest()
    with open(p, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def default_data_dir() -> Path:
    """Where datasets are installed: ``$MCNKIT_DATA`` if set, else ``./data`` (:func:`mcnkit.locations.data_dir`)."""
    return data_dir()


def find_houseexpo(data_dir: str | os.PathLike[str] | None = None) -> Path | None:
    """The installed ``houseexpo/json.tar.gz`` (or extracted ``houseexpo/json``), or None when absent."""
    base = Path(data_dir) if data_dir is not None else default_data_dir()
    for cand in (base / "houseexpo" / "json.tar.gz", base / "houseexpo" / "json", base / "json.tar.gz"):
        if cand.exists():
            return cand
    return None


def houseexpo_source(explicit: str | os.PathLike[str] | None = None) -> Path | None:
    """HouseExpo to read: ``explicit``, else the installed copy (:func:`find_houseexpo`), else the shared archive
    (``houseexpo/json.tar.gz`` under :func:`mcnkit.locations.shared_data_dir`); None when there is none."""
    if explicit is not None:
        return Path(explicit)
    shared = shared_data_dir() / "houseexpo" / "json.tar.gz"
    return find_houseexpo() or (shared if shared.is_file() else None)


def _open_source(src: str) -> tuple[BinaryIO, str]:
    parsed = urllib.parse.urlparse(src)
    if parsed.scheme in ("http", "https"):
        return urllib.request.urlopen(src, timeout=60), src
    if parsed.scheme == "file":
        local = urllib.request.url2pathname(parsed.path)
        return open(local, "rb"), local
    if parsed.scheme not in ("",) and len(parsed.scheme) > 1:
        raise ValueError(f"unsupported URL scheme {parsed.scheme!r} (use a path, file:// or http(s)://)")
    return open(src, "rb"), src


def install_houseexpo(
    src: str | os.PathLike[str], dest_dir: str | os.PathLike[str] | None = None, sha256: str | None = None
) -> Path:
    """Copies or downloads HouseExpo's ``json.tar.gz`` to ``<dest_dir>/houseexpo/json.tar.gz``, checking sha256.

    ``src`` is a path, a ``file://`` URL or an ``http(s)://`` URL.  ``dest_dir`` defaults to
    :func:`default_data_dir`.  The official split files ``map_id_train.txt`` / ``map_id_test.txt`` next to a
    local source are copied too.  ``sha256`` defaults to :data:`HOUSEEXPO_SHA256`; pass ``""`` to skip the check.

    Raises:
        ValueError: the digest does not match (nothing is left installed) or the scheme is unsupported.
        OSError: the source cannot be read.
    """
    expected = HOUSEEXPO_SHA256 if sha256 is None else sha256.lower().strip()
    target_dir = (Path(dest_dir) if dest_dir is not None else default_data_dir()) / "houseexpo"
    target_dir.mkdir(parents=True, exist_ok=True)
    target = target_dir / "json.tar.gz"
    stream, local = _open_source(os.fspath(src))
    h = hashlib.sha256()
    with stream as fin, tempfile.NamedTemporaryFile(dir=target_dir, delete=False, suffix=".part") as fout:
        tmp = Path(fout.name)
        for block in iter(lambda: fin.read(1 << 20), b""):
            h.update(block)
            fout.write(block)
    digest = h.hexdigest()
    if expected and digest != expected:
        tmp.unlink(missing_ok=True)
        raise ValueError(f"sha256 mismatch for {src}: got {digest}, expected {expected}")
    tmp.replace(target)
    src_dir = Path(local).parent
    if not local.startswith(("http://", "https://")):
        for name in ("map_id_train.txt", "map_id_test.txt"):
            if (src_dir / name).is_file() and src_dir.resolve() != target_dir.resolve():
                shutil.copyfile(src_dir / name, target_dir / name)
    return target
