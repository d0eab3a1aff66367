"""How a recording is laid out in the Rerun viewer: one blueprint for SLAM runs, one for MCN-SLAM runs (from
their number of ranks and samples), and the choice between them for a finished recording."""

from __future__ import annotations

import re

import rerun.blueprint as rrb

__all__ = ["APPLICATION_ID", "CLASSES", "METRICS", "SERIES", "mcn_blueprint", "recording_blueprint", "slam_blueprint"]

APPLICATION_ID = "mcnkit"
CLASSES = [(0, "free", (235, 235, 235)), (1, "unknown", (128, 128, 128)), (2, "occupied", (20, 20, 20))]


def slam_blueprint() -> rrb.Blueprint:
    """Map with particles, robot and scan on the left; metrics and the event log on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            # origin "/": a view ignores its origin's own transform, and /world's flips y up (map frame as in RViz)
            rrb.Spatial2DView(name="SLAM", origin="/", contents=["+ /world/**", "- /world/map/gt/**"]),
            rrb.Vertical(
                rrb.TimeSeriesView(name="metrics", origin="/metrics"),
                rrb.Tabs(rrb.Spatial2DView(name="ground truth", origin="/", contents=["+ /world/map/gt/**"]),
                         rrb.TextLogView(name="events", origin="/log"),
                         rrb.TextDocumentView(name="config", origin="/config")),
                row_shares=[1, 2],
            ),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline="step", expanded=True),
        collapse_panels=False,
    )


METRICS = {"f_slam": ((120, 120, 120), "F, SLAM map"), "f_completed": ((220, 60, 30), "F, completed"),
            "miou_unknown": ((30, 150, 60), "mIoU unknown cells"), "sample_diversity": ((150, 60, 200), "diversity")}
"""MCN scores recorded under ``/metrics/<key>``: colour and name of each series."""
SERIES = {**METRICS, "n_eff": ((30, 120, 220), "N_eff")}
"""Every ``/metrics`` series (the scores and N_eff): colour and name."""


def _map_view(name: str, entity: str, *extra: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(name=name, origin="/", contents=[f"+ {entity}/**", *(f"+ {e}" for e in extra)])


def mcn_blueprint(ranks: int, samples: int) -> rrb.Blueprint:
    """MCN-SLAM layout from (R, K): the SLAM view and metrics on the left; on the right one row per particle
    rank ``#r`` with its m_t, its K sampled completions ``s0…`` and their uncertainty; ground truth and events
    in tabs.  The blueprint and selection panels start collapsed (room for the views)."""
    rows = []
    for r in range(ranks):
        base = f"/world/mcn/rank{r}"
        robot = f"{base}/particle"
        views = [_map_view(f"#{r} m_t", f"{base}/window/partial", robot)]
        views += [_map_view(f"#{r} s{k}", f"{base}/window/sample{k}", robot) for k in range(samples)]
        views.append(_map_view(f"#{r} unc.", f"{base}/window/uncertainty", robot))
        rows.append(rrb.Horizontal(*views))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial2DView(name="SLAM", origin="/",
                                  contents=["+ /world/**", "- /world/map/gt/**", "- /world/mcn/**"]),
                rrb.Horizontal(
                    rrb.TimeSeriesView(name="scores", origin="/metrics", contents=["+ /metrics/**", "- /metrics/n_eff"]),
                    rrb.TimeSeriesView(name="N_eff", origin="/metrics/n_eff"),
                ),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                *rows,
                rrb.Tabs(rrb.Spatial2DView(name="ground truth", origin="/", contents=["+ /world/map/gt/**"]),
                         rrb.TextLogView(name="events", origin="/log"),
                         rrb.TextDocumentView(name="config", origin="/config")),
            ),
            column_shares=[2, 3],
        ),
        rrb.TimePanel(timeline="step", expanded=True),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )


def recording_blueprint(entity_paths: set[str]) -> rrb.Blueprint:
    """The layout for a recording with these entities: :func:`mcn_blueprint` with its (R, K) when it holds MCN
    completions, else :func:`slam_blueprint`."""
    found = [re.fullmatch(r"/world/mcn/rank(\d+)/window/sample(\d+)", e) for e in entity_paths]
    pairs = [(int(m.group(1)), int(m.group(2))) for m in found if m]
    if not pairs:
        return slam_blueprint()
    return mcn_blueprint(max(r for r, _ in pairs) + 1, max(k for _, k in pairs) + 1)


