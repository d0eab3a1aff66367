"""How a recording is laid out in the Rerun viewer: one blueprint for SLAM runs, one for MCN-SLAM runs (from
their number of ranks and samples), one for exploration runs, and the choice between them for a finished
recording."""

from __future__ import annotations

import re

import rerun.blueprint as rrb

__all__ = ["APPLICATION_ID", "CLASSES", "METRICS", "SERIES", "explore_blueprint", "mcn_blueprint", "recording_blueprint",
           "slam_blueprint"]

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


_PLAN_OVERLAY = ("/world/plan/viewpoints", "/world/plan/goal", "/world/plan/path", "/world/robot/estimate")
"""What every prediction view of an exploration recording also shows: the viewpoints, the goal, its path, the
robot."""


def explore_blueprint(samples: int) -> rrb.Blueprint:
    """Exploration layout: the map the robot plans on with its frontiers, viewpoints (scored), goal, path, scan and
    trajectory on the left, the coverage curve and the planning CPU under it; on the right (``samples`` > 0) the
    completions' window: the SLAM map on it, the samples' disagreement, the chosen goal's expected view and the K
    samples, each with the viewpoints and goal on top; ground truth (with the reachable space and what was seen),
    events and config in tabs."""
    explore = rrb.Spatial2DView(name="exploration", origin="/",
                                contents=["+ /world/**", "- /world/pred/**", "- /world/map/gt/**",
                                          "- /world/map/seen/**", "- /world/robot/truth/**"])
    left = rrb.Vertical(
        explore,
        rrb.Horizontal(rrb.TimeSeriesView(name="coverage", origin="/metrics/coverage"),
                       rrb.TimeSeriesView(name="planning CPU [ms]", origin="/metrics/plan_cpu_ms")),
        row_shares=[3, 1],
    )
    tabs = rrb.Tabs(rrb.Spatial2DView(name="ground truth", origin="/",
                                      contents=["+ /world/map/gt/**", "+ /world/map/seen/**", "+ /world/robot/truth/**",
                                                "+ /world/plan/goal"]),
                    rrb.TextLogView(name="events", origin="/log"),
                    rrb.TextDocumentView(name="config", origin="/config"))
    right: rrb.Container = tabs
    if samples > 0:
        views = [_map_view("m_t (window)", "/world/pred/window/partial", *_PLAN_OVERLAY),
                 _map_view("disagreement", "/world/pred/window/disagreement", *_PLAN_OVERLAY),
                 _map_view("goal's expected view", "/world/pred/window/view", *_PLAN_OVERLAY)]
        views += [_map_view(f"s{k}", f"/world/pred/window/sample{k}", *_PLAN_OVERLAY) for k in range(samples)]
        right = rrb.Vertical(rrb.Grid(*views, grid_columns=4 if len(views) > 9 else 3), tabs, row_shares=[3, 1])
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[3, 2] if samples > 0 else [2, 1]),
        rrb.TimePanel(timeline="step", expanded=True),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )


def recording_blueprint(entity_paths: set[str]) -> rrb.Blueprint:
    """The layout for a recording with these entities: :func:`explore_blueprint` for an exploration run,
    :func:`mcn_blueprint` with its (R, K) when it holds MCN completions, else :func:`slam_blueprint`."""
    if "/world/plan/goal" in entity_paths:
        samples = [re.fullmatch(r"/world/pred/window/sample(\d+)", e) for e in entity_paths]
        return explore_blueprint(max((int(m.group(1)) + 1 for m in samples if m), default=0))
    found = [re.fullmatch(r"/world/mcn/rank(\d+)/window/sample(\d+)", e) for e in entity_paths]
    pairs = [(int(m.group(1)), int(m.group(2))) for m in found if m]
    if not pairs:
        return slam_blueprint()
    return mcn_blueprint(max(r for r, _ in pairs) + 1, max(k for _, k in pairs) + 1)


