"""No module imports a module of a layer above its own (the layer that drives it).

The layers of ``mcnkit``, bottom to top (a module may import its own layer and those below):

0. **base**: ``mcnkit`` (the package: its version), ``types``, ``geometry``, ``grid``, and the helpers that
   import no other mcnkit module: ``_lazy`` (lazy package exports), ``locations`` (where data lives),
   ``threads`` (torch thread count), ``heap`` (big freed arrays returned to the OS), ``outputs`` (writing result
   files safely), ``exits`` (exit codes and the one-line report of bad input that every command uses).
1. **algorithms and data**: ``io`` (log readers and writers), ``slam`` (grid FastSLAM), ``completion`` (the
   networks, training, sampling, scores), ``datasets`` (floor plans, HouseExpo, training pairs), ``metrics``
   (trajectory errors, TUM files).
2. **MCN-SLAM and the simulator**: ``mcn`` (and ``mcn_config``, its settings without torch), ``sim``.
3. **what runs them**: ``drive`` (the loop over frames), ``sinks`` (its outputs), ``viz`` (Rerun), ``plots``
   (matplotlib), ``widgets`` (notebooks), ``runconfig`` (run settings from flags and files), ``recording`` (where a recording goes: file, live viewer), ``run``
   (MCN-SLAM on a log), ``demo``, ``experiments`` (the paper's experiments).
4. **commands**: ``cli`` (the ``mcnkit`` dispatcher) and the command modules of the packages: ``io.cli``,
   ``slam.cli``, ``slam.evaluate`` (``mcnkit eval``), ``datasets.cli``, ``completion.cli``, ``experiments.cli``.

Every import counts, also inside functions and under ``TYPE_CHECKING``; a module that is in no layer fails the
test too (place a new module in the table below).
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "mcnkit"

LAYERS: dict[str, int] = {
    "mcnkit": 0, "mcnkit._lazy": 0, "mcnkit.types": 0, "mcnkit.geometry": 0, "mcnkit.grid": 0,
    "mcnkit.locations": 0, "mcnkit.threads": 0, "mcnkit.heap": 0, "mcnkit.outputs": 0, "mcnkit.exits": 0,
    "mcnkit.io": 1, "mcnkit.slam": 1, "mcnkit.completion": 1, "mcnkit.datasets": 1, "mcnkit.metrics": 1,
    "mcnkit.mcn": 2, "mcnkit.mcn_config": 2, "mcnkit.sim": 2,
    "mcnkit.drive": 3, "mcnkit.sinks": 3, "mcnkit.viz": 3, "mcnkit.plots": 3, "mcnkit.widgets": 3,
    "mcnkit.runconfig": 3, "mcnkit.recording": 3, "mcnkit.run": 3, "mcnkit.demo": 3, "mcnkit.experiments": 3,
    "mcnkit.cli": 4, "mcnkit.io.cli": 4, "mcnkit.slam.cli": 4, "mcnkit.slam.evaluate": 4,
    "mcnkit.datasets.cli": 4, "mcnkit.completion.cli": 4, "mcnkit.experiments.cli": 4,
}  # fmt: skip
"""Module or package → layer; a module not listed takes the entry of the innermost listed package it is in
(``mcnkit`` itself stands for the package's ``__init__`` only)."""
NAMES = ("base", "algorithms and data", "MCN-SLAM and the simulator", "what runs them", "commands")


def layer(module: str) -> int | None:
    """The layer of ``module`` (dotted name), or None if the table places it nowhere."""
    if module in LAYERS:
        return LAYERS[module]
    parts = module.split(".")
    for n in range(len(parts) - 1, 1, -1):  # the packages it is in, not the bare "mcnkit"
        hit = LAYERS.get(".".join(parts[:n]))
        if hit is not None:
            return hit
    return None


def module_name(path: Path, root: Path = PACKAGE) -> str:
    """``mcnkit/io/cli.py`` → ``mcnkit.io.cli``; a package's ``__init__.py`` → the package."""
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
    """(every import of a module from a higher layer, as ``importer (layer) → imported (layer)``; the modules
    that are in no layer)."""
    offenders: list[str] = []
    unplaced: list[str] = []
    for path in sorted(root.rglob("*.py")):
        name = module_name(path, root)
        own = layer(name)
        if own is None:
            unplaced.append(name)
            continue
        for target in sorted(imported_modules(path.read_text(), name, path.name == "__init__.py", root)):
            theirs = layer(target)
            if theirs is None:
                unplaced.append(target)
            elif theirs > own:
                offenders.append(f"{name} ({NAMES[own]}) imports {target} ({NAMES[theirs]})")
    return offenders, sorted(set(unplaced))


def test_no_module_imports_a_layer_above_its_own() -> None:
    offenders, unplaced = upward_imports()
    assert not unplaced, f"modules in no layer (add them to LAYERS): {unplaced}"
    assert not offenders, "upward imports:\n" + "\n".join(offenders)


def test_the_check_finds_an_upward_import_anywhere_in_a_module(tmp_path: Path) -> None:
    pkg = tmp_path / "mcnkit"
    (pkg / "io").mkdir(parents=True)
    for f in ("__init__.py", "grid.py", "cli.py", "mcn.py", "io/__init__.py", "io/cli.py", "extra.py"):
        (pkg / f).write_text("")
    (pkg / "grid.py").write_text("import numpy\nfrom mcnkit import types\n\n\ndef f():\n    from .mcn import x\n")
    (pkg / "io" / "__init__.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                            "    from . import cli\n")
    (pkg / "mcn.py").write_text("from mcnkit.cli import fail\nfrom mcnkit.io.cli import describe\n")
    (pkg / "cli.py").write_text("import mcnkit.mcn\nfrom mcnkit.io import open_log\n")
    offenders, unplaced = upward_imports(pkg)
    assert offenders == [
        "mcnkit.grid (base) imports mcnkit.mcn (MCN-SLAM and the simulator)",
        "mcnkit.io (algorithms and data) imports mcnkit.io.cli (commands)",
        "mcnkit.mcn (MCN-SLAM and the simulator) imports mcnkit.cli (commands)",
        "mcnkit.mcn (MCN-SLAM and the simulator) imports mcnkit.io.cli (commands)",
    ]
    assert unplaced == ["mcnkit.extra"]
