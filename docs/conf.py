"""Sphinx configuration of mcnkit's documentation (``make docs`` serves it; ``make test`` builds it with -W).

The guide pages are Markdown (MyST); the API reference is generated at build time from the docstrings
(autosummary over the whole ``mcnkit`` package into ``docs/api/generated/``, which git ignores).  mcnkit's own
cross-references are checked (nitpicky); names from other libraries are left unlinked, because the build is
offline and has no inventories to resolve them against.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the checkout's mcnkit, also when the venv holds another install
os.environ.setdefault("RERUN_ANALYTICS", "0")

project = "mcnkit"
author = "the mcnkit developers"
copyright = "mcnkit developers"
release = version = "0.1.0"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build"]
templates_path = ["_templates"]
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_ignore_module_all = True
autodoc_default_options = {"members": True, "ignore-module-all": True, "member-order": "bysource",
                           "show-inheritance": True}
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
autodoc_mock_imports: list[str] = []
add_module_names = False
python_maximum_signature_line_length = 100

nitpicky = True

html_theme = "furo"
html_title = "mcnkit"
html_static_path: list[str] = []
html_theme_options = {"navigation_with_keys": True}
html_copy_source = False
html_show_sourcelink = False


def _py_objects(env: Any) -> dict[str, Any]:
    """mcnkit's documented Python objects by full name (the py domain's table)."""
    return env.get_domain("py").objects  # type: ignore[no-any-return]


def _canonical(target: str) -> str | None:
    """Where a re-exported name is documented: ``mcnkit.io.open_log`` → ``mcnkit.io.open.open_log``."""
    import importlib

    parts = target.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        try:
            for name in parts[cut:]:
                obj = getattr(obj, name)
        except AttributeError:
            return None
        module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
        return f"{module}.{qualname}" if module and qualname else None
    return None


def _resolve(app: Any, env: Any, node: Any, contnode: Any) -> Any:
    """Resolves what the py domain leaves unresolved in mcnkit's docstrings: a name through the package that
    re-exports it (``mcnkit.slam.FastSlam``), or a short name (``LogError``) that one documented object bears."""
    from sphinx.util.nodes import make_refnode

    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "").lstrip("~.")
    objects = _py_objects(env)
    name = _canonical(target) if target.startswith("mcnkit.") else None
    if name is None or name not in objects:
        matches = [full for full in objects if full.startswith("mcnkit.") and full.endswith("." + target)]
        if len(matches) > 1:  # prefer the one nearest to the referring module
            here = node.get("py:module") or ""
            near = [m for m in matches if m.startswith(here.rsplit(".", 1)[0] + ".")]
            matches = near if len(near) == 1 else matches
        name = matches[0] if len(matches) == 1 else None
    if name is None:
        return None
    entry = objects[name]
    return make_refnode(app.builder, node["refdoc"], entry.docname, entry.node_id, contnode, name)


def _warn_missing(app: Any, domain: Any, node: Any) -> bool | None:
    """Keeps the warning for an unresolved reference to mcnkit's own names, drops it for other libraries' (the
    build is offline: no inventories), for private names and for type variables, which are not documented."""
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "").lstrip("~.")
    last = target.rsplit(".", 1)[-1]
    if last.startswith("_") or (len(last) == 1 and last.isupper()):
        return True
    if target.startswith("mcnkit."):
        return None
    names = {full.rsplit(".", 1)[-1] for full in _py_objects(app.env) if full.startswith("mcnkit.")}
    return None if "." not in target and target in names else True


def _pipe_tables(lines: list[str]) -> list[str]:
    """Markdown pipe tables (``| a | b |`` rows under a ``|---|`` rule), which some module docstrings hold, as
    reST list tables."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        row = lines[i].strip()
        rule = lines[i + 1].strip() if i + 1 < len(lines) else ""
        if not (row.startswith("|") and rule.startswith("|") and set(rule) <= set("|-: ")):
            out.append(lines[i])
            i += 1
            continue
        indent = lines[i][: len(lines[i]) - len(lines[i].lstrip())]
        rows = [row]
        i += 2
        while i < len(lines) and lines[i].strip().startswith("|"):
            rows.append(lines[i].strip())
            i += 1
        if out and out[-1].strip():
            out.append("")
        out += [f"{indent}.. list-table::", f"{indent}   :header-rows: 1", ""]
        for r in rows:
            cells = [c.strip() for c in r.strip("|").split("|")]
            out += [f"{indent}   * - {cells[0]}"] + [f"{indent}     - {c}" for c in cells[1:]]
        out.append("")
    return out


def _docstring(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    """Reads a docstring as its authors wrote it: Google-style ``Args:``/``Returns:``/``Raises:`` sections in
    functions, classes and modules (an attribute's one-line docstring is text, even with a colon in it), and
    ``size``² (a literal right before a superscript, which reST needs escaped), Markdown pipe tables."""
    import re

    from sphinx.ext.napoleon import Config
    from sphinx.ext.napoleon.docstring import GoogleDocstring

    if what in ("module", "class", "exception", "function", "method"):
        lines[:] = GoogleDocstring(lines, Config(napoleon_use_ivar=True, napoleon_use_rtype=False), app, what,
                                   name, obj, options).lines()
    lines[:] = [re.sub(r"``(?=[²³])", r"``\\ ", line) for line in _pipe_tables(lines)]


def setup(app: Any) -> None:
    """Registers the docstring reader, the reference resolver and its filter."""
    app.connect("autodoc-process-docstring", _docstring)
    app.connect("missing-reference", _resolve)
    app.connect("warn-missing-reference", _warn_missing)
