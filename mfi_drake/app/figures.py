"""The figures: a scenario's flights (the paper's Figs 5–9, 11: the 3-D path
with the obstacles, its top view, the path length and the position error
over time; each method in its own colour, line style and markers) and the
sweep's success rates and path ratios. A moving obstacle is drawn where it
was at the start (faint) and at the end, with its centre's path dashed; the
other vehicles' paths are thinner, in their method's style; a ground is a
green plane under the 3-D view.

Figures are `matplotlib.figure.Figure` objects, never pyplot's: drawing
here leaves the user's matplotlib backend alone. `write_figure` is the one
place a figure reaches the disk, atomically.
"""

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from mfi_drake.config.dynamic import moves
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import atomic_path
from mfi_drake.flight.methods import appearance
from mfi_drake.flight.result import outcome as flight_outcome
from mfi_drake.studies.stats import summary_groups
from mfi_drake.world.motion import obstacle_position
from mfi_drake.world.obstacles import obstacle_triangles
from mfi_drake.world.shapes import bounding_radius

OUTCOME_WORDS = {
    "success": "reached",
    "collision": "collided",
    "timeout": "failed",
    "trapped": "trapped",
}


def write_figure(fig: Figure, path: str, dpi: int = 110) -> None:
    """Saves `fig` to `path` (format from its extension), complete or not at
    all."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.rsplit(".", 1)[-1])


MAP_DRAWN = 20_000  # points of a point-cloud map drawn at most (evenly strided)
MAP_STYLE = {"color": (0.35, 0.35, 0.4), "s": 2.0, "alpha": 0.5, "linewidths": 0}


def map_drawn(scenario: Scenario) -> np.ndarray:
    """(k, 3): the points of the scenario's point-cloud map that figures
    draw (all, or every n-th beyond MAP_DRAWN); none without a map."""
    points = np.asarray(scenario.map_points, dtype=float).reshape(-1, 3)
    return points[:: -(-len(points) // MAP_DRAWN) or 1]


def _static_triangles(scenario: Scenario) -> np.ndarray:
    """(T, 3, 3): the triangles of every obstacle that does not move, at
    rest, in one array: drawn as one collection, not one artist an
    obstacle (matplotlib's cost a collection made a 1,000-obstacle world's
    figure take 40 s)."""
    still = [
        obstacle_triangles(scenario, o, 0.0)
        for o in scenario.obstacles
        if not moves(o.motion)
    ]
    return np.concatenate(still) if still else np.zeros((0, 3, 3))


def _obstacle_layers(ax, scenario: Scenario, times, still, shades, dims: int) -> list:
    """The obstacles of `draw_obstacles` (`dims` 3) or `draw_footprints` (2)
    as (triangles, shade): the still ones (shades[0]) and each moving one at
    times[0] and times[-1] (shades[1], shades[2]); drawn here, each mover's
    centre path over `times` dashed and a point-cloud map as a light
    scatter."""
    if scenario.map_points:
        behind = {"zorder": 0} if dims == 2 else {}
        ax.scatter(*map_drawn(scenario)[:, :dims].T, **behind, **MAP_STYLE)
    still = _static_triangles(scenario) if still is None else still
    drawn = [(still, shades[0])] if len(still) else []
    for obstacle in filter(lambda o: moves(o.motion), scenario.obstacles):
        drawn += [
            (obstacle_triangles(scenario, obstacle, times[0]), shades[1]),
            (obstacle_triangles(scenario, obstacle, times[-1]), shades[2]),
        ]
        centres = obstacle_position(obstacle, np.asarray(times))
        ax.plot(*centres[:, :dims].T, color="grey", ls="--", lw=0.8)
    return drawn


def draw_obstacles(ax, scenario: Scenario, times=(0.0,), still=None) -> None:
    """The obstacles at times[0] and, those that move, at times[-1] too (the
    first faint) with their centre's path over `times` dashed; a
    point-cloud map as a light scatter. `still`: `_static_triangles`, if
    already computed."""
    shades = (0.35, 0.12, 0.35)  # alphas
    for triangles, alpha in _obstacle_layers(ax, scenario, times, still, shades, 3):
        ax.add_collection3d(
            Poly3DCollection(
                triangles,
                facecolor=(0.6, 0.6, 0.65, alpha),
                edgecolor=(0.4, 0.4, 0.45, alpha / 2),
                linewidth=0.3,
            )
        )


def draw_footprints(ax, scenario: Scenario, times=(0.0,), still=None) -> None:
    """The top view of `draw_obstacles`: each obstacle's x–y footprint (its
    triangles projected, one flat colour so that overlaps do not darken)."""
    shades = (0.78, 0.9, 0.78)  # greys
    for triangles, grey in _obstacle_layers(ax, scenario, times, still, shades, 2):
        colour = (grey, grey, grey + 0.03)
        ax.add_collection(
            PolyCollection(
                triangles[:, :, :2],
                facecolor=colour,
                edgecolor=colour,
                linewidth=0.5,
                zorder=0,
            )
        )


def draw_ground(ax, height: float) -> None:
    """A plane at z = height over the axes' x and y limits."""
    x, y = np.meshgrid(ax.get_xlim(), ax.get_ylim())
    ax.plot_surface(x, y, np.full_like(x, height), color=(0.45, 0.6, 0.4), alpha=0.25)


def _equal_box(ax, points: np.ndarray) -> None:
    """Equal, square limits holding `points` (N, 2) or (N, 3) on `ax`."""
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, max(0.53 * (high - low).max(), 0.5)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    if points.shape[1] == 3:
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1, 1, 1))
    else:
        ax.set_aspect("equal")


# Where paths overlap (APF's under GF's at the wall), each method keeps its
# own line style and marker, its markers staggered along the path from the
# other methods'.
LINE_STYLES = ("-", "--", "-.", ":")
MARKERS = ("o", "s", "^", "D", "v", "P")
MARKER_SPACING = 1.0  # m of path between one method's markers


def method_style(i: int, count: int, path: np.ndarray) -> dict:
    """Line style, marker and marked samples of the i-th of `count` methods,
    flown along `path` (N, 3)."""
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    marks = np.arange(MARKER_SPACING * (i + 0.5) / count, arc[-1], MARKER_SPACING)
    style = {"ls": LINE_STYLES[i % len(LINE_STYLES)]}
    if count > 1:  # one method alone needs no markers
        style["marker"] = MARKERS[i % len(MARKERS)]
        style["markersize"] = 4.5
        style["markevery"] = np.unique(np.searchsorted(arc, marks)).tolist()
    return style


def plot_flights(scenario: Scenario, flights: list, path: str, title: str = "") -> None:
    """Writes the figure of one scenario flown by one or more methods."""
    write_figure(flights_figure(scenario, flights, title), path)


def _draw_ends(ax3d, ax_top, scenario: Scenario) -> None:
    """Every vehicle's start (a dot) and goal (a star) in the 3-D and the
    top view; labelled once, in the 3-D view."""
    ends = [(scenario.start, scenario.goal)] + [
        (o.start, o.goal) for o in scenario.other_vehicles
    ]
    for k, (a, b) in enumerate(ends):
        for ax, dims in ((ax3d, slice(0, 3)), (ax_top, slice(0, 2))):
            ax.scatter(
                *np.asarray(a)[dims],
                color="black",
                marker="o",
                s=40,
                zorder=5,
                label="start" if k == 0 and ax is ax3d else None,
            )
            ax.scatter(
                *np.asarray(b)[dims],
                color="gold",
                edgecolor="black",
                marker="*",
                s=160,
                zorder=5,
                label="goal" if k == 0 and ax is ax3d else None,
            )


def flights_figure(scenario: Scenario, flights: list, title: str = "") -> Figure:
    """The figure of one scenario flown by one or more methods: the 3-D view,
    the top (x–y) view, path length and position error."""
    fig = Figure(figsize=(18, 6.5))
    grid = fig.add_gridspec(2, 3, width_ratios=(1.15, 1.0, 1.1))
    ax3d = fig.add_subplot(grid[:, 0], projection="3d")
    ax_top = fig.add_subplot(grid[:, 1])
    ax_len = fig.add_subplot(grid[0, 2])
    ax_err = fig.add_subplot(grid[1, 2])
    times = flights[0].times if flights else np.zeros(1)
    still = _static_triangles(scenario)
    draw_obstacles(ax3d, scenario, times, still)
    draw_footprints(ax_top, scenario, times, still)
    start, goal = np.asarray(scenario.start), np.asarray(scenario.goal)
    corners = [start, goal, map_drawn(scenario)]
    for obstacle in scenario.obstacles:  # wherever it went, all of it
        reach = bounding_radius(scenario, obstacle.shape)
        centres = np.atleast_2d(obstacle_position(obstacle, times))
        corners += [centres - reach, centres + reach]
    for i, flight in enumerate(flights):
        label, colour = appearance(flight.method)
        outcome = OUTCOME_WORDS[flight_outcome(flight.metrics)]
        for k, flown in enumerate([flight, *flight.others]):
            first = k == 0  # the scenario's own vehicle; the others thinner
            p = flown.positions
            style = {"color": colour, **method_style(i, len(flights), p)}
            style["lw"] = 1.8 if first else 1.0
            corners.append(p)
            name = f"{label} ({outcome})" if first else None
            ax3d.plot(p[:, 0], p[:, 1], p[:, 2], label=name, **style)
            ax_top.plot(p[:, 0], p[:, 1], **style)
            steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
            length = np.concatenate([[0.0], np.cumsum(steps)])
            ax_len.plot(flown.times, length, **style)
            error = np.linalg.norm(p - np.asarray(flown.scenario.goal), axis=1)
            ax_err.plot(flown.times, error, **style)
    _draw_ends(ax3d, ax_top, scenario)
    points = np.vstack([np.atleast_2d(c) for c in corners])
    _equal_box(ax3d, points)
    if scenario.ground is not None:
        draw_ground(ax3d, scenario.ground.height)
    ax3d.set_xlabel("x [m]")
    ax3d.set_ylabel("y [m]")
    ax3d.set_zlabel("z [m]")
    ax3d.set_title("centre-of-mass trajectory")
    _equal_box(ax_top, points[:, :2])
    ax_top.set_xlabel("x [m]")
    ax_top.set_ylabel("y [m]")
    ax_top.set_title("top view")
    ax_top.grid(alpha=0.3)
    ax_len.set_ylabel("path length [m]")
    ax_len.grid(alpha=0.3)
    ax_err.set_ylabel("position error |p − p_g| [m]")
    ax_err.set_xlabel("time [s]")
    ax_err.axhline(scenario.goal_tolerance, color="grey", ls=":", lw=1)
    ax_err.grid(alpha=0.3)
    ax_len.set_xlabel("time [s]")
    handles, labels = ax3d.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=9)
    fig.suptitle(title or f"{scenario.name} ({as_vehicle(scenario.vehicle).name})")
    fig.tight_layout(rect=(0, 0.06, 1, 0.95))
    return fig


def write_comparison_figure(scenario: Scenario, flights: list, path: str) -> None:
    """The figure of one scenario flown by several methods."""
    names = ", ".join(appearance(f.method)[0] for f in flights)
    plot_flights(scenario, flights, path, title=f"{scenario.name}: {names}")


def _with_ci(ax, rows: list, key: str, **style) -> None:
    """s[key] at x with its 95 % interval s[key + "_ci95"] as error bars,
    for each (x, s) of `rows`."""
    x = np.array([x for x, _ in rows])
    value = np.array([s[key] for _, s in rows])
    ci = np.array([s[f"{key}_ci95"] for _, s in rows])
    yerr = [value - ci[:, 0], ci[:, 1] - value]
    ax.errorbar(x, value, yerr=yerr, marker="o", capsize=3, **style)


def plot_sweep(summary: dict, path: str) -> None:
    """Success rate and path ratio against density (or world class), one
    line per method."""
    fig = Figure(figsize=(11, 4.2))
    ax_s, ax_r = fig.subplots(1, 2)
    methods = summary["methods"]
    heading, groups = summary_groups(next(iter(methods.values())))
    # Density on the axis, or the world classes one a tick.
    at = {g: float(g) for g in groups} if "density" in heading else {}
    at = at or {g: float(i) for i, g in enumerate(groups)}
    ticks = list(at.values())
    # Methods side by side at each density, so that their bars do not hide
    # each other.
    dodge = 0.015 * (max(ticks) - min(ticks) or max(ticks) or 1.0)
    for i, (method, pooled) in enumerate(methods.items()):
        rows = [(at[g], s) for g, s in summary_groups(pooled)[1].items() if s["n"]]
        if not rows:
            continue
        shift = dodge * (i - (len(methods) - 1) / 2)
        rows = [(x + shift, s) for x, s in rows]
        label, colour = appearance(method)
        _with_ci(ax_s, rows, "success_rate", color=colour, label=label)
        ok = [(x, s) for x, s in rows if s["median_path_ratio"] is not None]
        if ok:
            _with_ci(
                ax_r, ok, "median_path_ratio", color=colour, label=f"{label} median"
            )
            ax_r.plot(
                [x for x, _ in ok],
                [s["p90_path_ratio"] for _, s in ok],
                color=colour,
                ls=":",
                marker="^",
                mfc="none",
                label=f"{label} 90th pct",
            )
    ax_s.set_ylim(-0.02, 1.02)
    ax_s.set_ylabel("success rate (95% Wilson CI)")
    ax_r.set_ylabel("path length / reference shortest path")
    for ax in (ax_s, ax_r):
        if "density" in heading:
            ax.set_xlabel("obstacle density [obstacles / m³]")
            ax.set_xticks(ticks)
        else:
            ax.set_xticks(ticks, list(at), rotation=20)
        ax.set_xlim(min(ticks) - 10 * dodge, max(ticks) + 10 * dodge)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:  # no ratios when nothing succeeded
            ax.legend(fontsize=8)
    what = "random fields" if "density" in heading else "generated worlds"
    per = "density" if "density" in heading else "class"
    fig.suptitle(
        f"{summary['flights']} flights on {what} "
        f"(seed {summary['config']['seed']}, "
        f"{summary['config']['n']} fields per {per})"
    )
    fig.tight_layout()
    write_figure(fig, path)


# What a fleet sweep counts per field, with the hatch that marks it.
FLEET_OUTCOMES = (
    ("success_rate", "success_rate_ci95", "every vehicle succeeds", ""),
    ("vehicle_contact_fields", None, "vehicle–vehicle contact", "//"),
    ("obstacle_collision_fields", None, "vehicle–obstacle collision", "xx"),
    ("deadlock_fields", None, "deadlock (time-out)", ".."),
)


def plot_fleet_sweep(summary: dict, path: str) -> None:
    """A fleet sweep (`studies.fleet_sweep`): per method and density, the
    share of fields of each outcome (95 % Wilson CI), the least separation
    (median field and least of all) and the path ratio (median with its CI,
    90th percentile)."""
    fig = Figure(figsize=(13, 4.4))
    ax_o, ax_s, ax_r = fig.subplots(1, 3)
    groups = [
        (method, float(d), s)
        for method, by_density in summary["methods"].items()
        for d, s in by_density.items()
        if s["n"]
    ]
    several = len({d for _, d, _ in groups}) > 1
    names = [
        appearance(m)[0] + (f"\n{d:g} /m³" if several else "") for m, d, _ in groups
    ]
    x = np.arange(len(groups))
    width = 0.8 / len(FLEET_OUTCOMES)
    middle = (len(FLEET_OUTCOMES) - 1) / 2  # the bars centred on each group
    for k, (key, ci_key, _, hatch) in enumerate(FLEET_OUTCOMES):
        shares, lows, highs = [], [], []
        for _, _, s in groups:
            share, ci = (
                (s[key], s[ci_key]) if ci_key else (s[key]["rate"], s[key]["ci95"])
            )
            shares.append(share)
            lows.append(share - ci[0])
            highs.append(ci[1] - share)
        ax_o.bar(
            x + (k - middle) * width,
            shares,
            width,
            yerr=[lows, highs],
            capsize=2,
            color=[appearance(m)[1] for m, _, _ in groups],
            alpha=1.0 if k == 0 else 0.45,
            hatch=hatch,
            edgecolor="black",
            linewidth=0.5,
        )
    ax_o.set_ylim(0.0, 1.05)
    ax_o.set_ylabel("share of fields (95% Wilson CI)")
    # The bars take their method's colour: the legend says what each hatch counts.
    hatches = [
        Patch(facecolor="lightgrey", edgecolor="black", hatch=hatch, label=label)
        for _, _, label, hatch in FLEET_OUTCOMES
    ]
    fig.legend(handles=hatches, loc="lower center", ncol=4, fontsize=8)
    for i, (m, _, s) in enumerate(groups):
        colour = appearance(m)[1]
        if s["median_min_separation"] is not None:
            ax_s.plot(i, s["median_min_separation"], "o", color=colour)
            ax_s.plot(i, s["least_min_separation"], "v", color=colour, mfc="none")
        if s["median_path_ratio"] is not None:
            ci = s["median_path_ratio_ci95"]
            med = s["median_path_ratio"]
            ax_r.errorbar(
                i, med, yerr=[[med - ci[0]], [ci[1] - med]], color=colour, marker="o"
            )
            ax_r.plot(i, s["p90_path_ratio"], "^", color=colour, mfc="none")
    ax_s.axhline(0.0, color="black", lw=0.8)
    ax_s.set_ylabel("least separation of a field [m]\n(o median field, ▽ least)")
    ax_r.set_ylabel("path length / shortest path\n(o median with 95% CI, △ 90th pct)")
    for ax in (ax_o, ax_s, ax_r):
        ax.set_xticks(x, names, fontsize=8)
        ax.grid(alpha=0.3, axis="y")
    config = summary["config"]
    fig.suptitle(
        f"{config['vehicles']} vehicles a field: {summary['flights']} fleets on "
        f"random fields (seed {config['seed']}, {config['n']} fields per density)"
    )
    fig.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    write_figure(fig, path)
