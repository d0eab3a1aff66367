"""Display: the only package that imports rerun or ipywidgets.

Rerun recordings of runs (:mod:`~mcnkit.viz.logger`: the logger; :mod:`~mcnkit.viz.blueprints`: their layout;
:mod:`~mcnkit.viz.streams`: one recording sent to a file and live viewers; :mod:`~mcnkit.viz.columns`: steps
batched into columns; :mod:`~mcnkit.viz.webviewer`: Rerun's web viewer on 127.0.0.1; :mod:`~mcnkit.viz.files`:
finished ``.rrd`` files; :mod:`~mcnkit.viz.record`: the sink that records a drive, and :func:`run_mcn`), notebook
widgets (:mod:`~mcnkit.viz.widgets`) and static matplotlib figures (:mod:`~mcnkit.viz.plots`).

The names below are imported on first use: ``import mcnkit.viz.plots`` does not load rerun."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.viz.blueprints import APPLICATION_ID, mcn_blueprint, recording_blueprint, slam_blueprint
    from mcnkit.viz.files import optimize_recording, recording_viewer
    from mcnkit.viz.logger import RerunLogger
    from mcnkit.viz.record import RecordingSink, announce_live, mcn_sinks, recording_logger, run_mcn, serve_on

__all__ = ["APPLICATION_ID", "RecordingSink", "RerunLogger", "announce_live", "mcn_blueprint", "mcn_sinks",
           "optimize_recording", "recording_blueprint", "recording_logger", "recording_viewer", "run_mcn", "serve_on",
           "slam_blueprint"]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.viz.blueprints": ("APPLICATION_ID", "mcn_blueprint", "recording_blueprint", "slam_blueprint"),
    "mcnkit.viz.files": ("optimize_recording", "recording_viewer"),
    "mcnkit.viz.logger": ("RerunLogger",),
    "mcnkit.viz.record": ("RecordingSink", "announce_live", "mcn_sinks", "recording_logger", "run_mcn", "serve_on"),
})
