"""What every notebook generator shares: the cell constructors and a writer that gives stable cell ids, so
regenerating a notebook gives the same file."""

from pathlib import Path

import nbformat as nbf

NOTEBOOKS = Path(__file__).resolve().parents[1]
md, code = nbf.v4.new_markdown_cell, nbf.v4.new_code_cell


def save(cells: list, name: str) -> None:
    """Writes ``cells`` (outputs empty) as ``notebooks/<name>``; cell ids are ``nbNN-II``."""
    nb = nbf.v4.new_notebook()
    nb.cells = cells
    for i, cell in enumerate(cells):
        cell.id = f"nb{name[:2]}-{i:02d}"
    nb.metadata["kernelspec"] = {"display_name": "Python 3", "language": "python", "name": "python3"}
    nbf.write(nb, NOTEBOOKS / name)
