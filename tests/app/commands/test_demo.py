"""Where ``mcnkit demo`` tells a user to watch its recording: only at what the user has."""

from pathlib import Path

import pytest

from mcnkit.app.commands.demo import _notebook_hint

ROOT = Path(__file__).resolve().parents[3]


def test_a_checkout_is_pointed_at_its_quickstart_notebook(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    assert _notebook_hint(Path("recordings/demo/demo.rrd")) == "open notebooks/01_quickstart.ipynb"


def test_an_installed_wheel_is_pointed_at_no_notebook_it_lacks(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # no notebooks/ here, as for a wheel installed outside the checkout
    hint = _notebook_hint(Path("out/demo.rrd"))
    assert "ipynb" not in hint
    assert hint == f'mcnkit.viz.recording_viewer("{(tmp_path / "out/demo.rrd").resolve()}").display()'
