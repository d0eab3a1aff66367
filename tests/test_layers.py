"""No module imports a module of a layer above its own: the folder tree is the layer diagram.

``LAYERS`` lists the layers of ``mcnkit`` bottom to top, each as the paths (files or folders, relative to
``mcnkit/``) that make it up; a module belongs to the longest path that holds it, and every module of the package
must be under one.  A module may import its own layer and those below.  Every import counts, also inside functions
and under ``TYPE_CHECKING``.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "mcnkit"

LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("base", ("__init__.py", "_lazy.py", "types.py", "geometry.py", "grid.py", "locations.py", "threads.py")),
    ("library", ("io", "slam", "completion", "datasets", "metrics.py")),
    ("MCN-SLAM and the simulator", ("mcn.py", "mcn_config.py", "sim.py")),
    ("exploration", ("explore",)),
    ("application", ("app",)),
    ("display", ("viz",)),
    ("experiments", ("experiments",)),
    ("commands", ("app/commands", "app/main.py")),
)
"""Bottom to top: exploration (``explore/``, a robot that plans where to look) on MCN-SLAM and the simulator, the
application's loop, sinks and settings (``app/``) under the display that records and shows its runs (``viz/``), the
paper's experiments over both, and the commands (``app/commands/``, ``app/main.py``) over everything."""


def layer(module: str, root: Path = PACKAGE) -> int | None:
    """The layer of ``module`` (dotted name): that of the longest ``LAYERS`` path holding it; None if none does."""
    parts = module.split(".")[1:]
    path = "/".join(parts) if parts else "__init__.py"
    best: tuple[int, int] | None = None  # (length of the matching path, layer)
    for index, (_, paths) in enumerate(LAYERS):
        for p in paths:
            stem = p.removesuffix(".py")
            if path == stem or path.startswith(stem + "/") or (p == "__init__.py" and not parts):
                if best is None or len(stem) > best[0]:
                    best = (len(stem), index)
    return None if best is None else best[1]


def module_name(path: Path, root: Path = PACKAGE) -> str:
    """``mcnkit/io/open.py`` → ``mcnkit.io.open``; a package's ``__init__.py`` → the package."""
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _exists(module: str, root: Path) -> bool:
    base = root.parent.joinpath(*module.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def imported_modules(source: str, module: str, is_package: bool, root: Path = PACKAGE) -> set[str]:
    """The mcnkit modules ``source`` (of ``module``) imports anywhere: ``from a.b import c`` counts ``a.b.c``
    when that is a module, else ``a.b``; relative imports are resolved."""
    out: set[str] = set()
    here = module.split(".") if is_package else module.split(".")[:-1]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = here[: len(here) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.add(sub if _exists(sub, root) else base)
    return {m for m in out if m == "mcnkit" or m.startswith("mcnkit.")}


def upward_imports(root: Path = PACKAGE) -> tuple[list[str], list[str]]:
    """(every import of a module from a higher layer, as ``importer (layer) imports imported (layer)``; the modules
    that are in no layer)."""
    offenders: list[str] = []
    unplaced: list[str] = []
    for path in sorted(root.rglob("*.py")):
        name = module_name(path, root)
        own = layer(name, root)
        if own is None:
            unplaced.append(name)
            continue
        for target in sorted(imported_modules(path.read_text(), name, path.name == "__init__.py", root)):
            theirs = layer(target, root)
            if theirs is None:
                unplaced.append(target)
            elif theirs > own:
                offenders.append(f"{name} ({LAYERS[own][0]}) imports {target} ({LAYERS[theirs][0]})")
    return offenders, sorted(set(unplaced))


def test_no_module_imports_a_layer_above_its_own() -> None:
    offenders, unplaced = upward_imports()
    assert not unplaced, f"modules in no layer (add their folder or file to LAYERS): {unplaced}"
    assert not offenders, "upward imports:\n" + "\n".join(offenders)


def test_only_viz_imports_rerun_or_ipywidgets() -> None:
    outside = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.relative_to(PACKAGE).parts[0] == "viz":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            outside += [f"{module_name(path)}: {n}" for n in names if n.split(".")[0] in ("rerun", "ipywidgets")]
    assert not outside, outside


def test_the_check_finds_an_upward_import_anywhere_in_a_module(tmp_path: Path) -> None:
    pkg = tmp_path / "mcnkit"
    (pkg / "io").mkdir(parents=True)
    (pkg / "app" / "commands").mkdir(parents=True)
    for f in ("__init__.py", "grid.py", "mcn.py", "io/__init__.py", "io/open.py", "app/__init__.py", "app/exits.py",
              "app/commands/__init__.py", "app/commands/info.py", "extra.py"):
        (pkg / f).write_text("")
    (pkg / "grid.py").write_text("import numpy\nfrom mcnkit import types\n\n\ndef f():\n    from .mcn import x\n")
    (pkg / "io" / "__init__.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                            "    from ..app.commands import info\n")
    (pkg / "mcn.py").write_text("from mcnkit.app.exits import fail\nfrom mcnkit.app.commands.info import describe\n")
    (pkg / "app" / "exits.py").write_text("import mcnkit.app.commands.info\nfrom mcnkit.io import open_log\n")
    (pkg / "app" / "commands" / "info.py").write_text("import mcnkit.mcn\nfrom mcnkit.app.exits import fail\n")
    offenders, unplaced = upward_imports(pkg)
    assert offenders == [
        "mcnkit.app.exits (application) imports mcnkit.app.commands.info (commands)",
        "mcnkit.grid (base) imports mcnkit.mcn (MCN-SLAM and the simulator)",
        "mcnkit.io (library) imports mcnkit.app.commands.info (commands)",
        "mcnkit.mcn (MCN-SLAM and the simulator) imports mcnkit.app.commands.info (commands)",
        "mcnkit.mcn (MCN-SLAM and the simulator) imports mcnkit.app.exits (application)",
    ]
    assert unplaced == ["mcnkit.extra"]
