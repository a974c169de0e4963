"""The figures: a scenario's flights (the paper's Figs 5–9, 11: the 3-D path
with the obstacles, the path length and the position error over time) and
the sweep's success rates and path ratios. A moving obstacle is drawn where
it was at the start (faint) and at the end, with its centre's path dashed;
the other vehicles' paths are dashed in their method's colour; a ground is a
green plane under the scene.

Figures are `matplotlib.figure.Figure` objects, never pyplot's: drawing
here leaves the user's matplotlib backend alone. `write_figure` is the one
place a figure reaches the disk, atomically.
"""

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from mfi_drake.config.dynamic import moves
from mfi_drake.config.scenario import Scenario
from mfi_drake.files import atomic_path
from mfi_drake.flight.methods import appearance
from mfi_drake.flight.simulation import outcome as flight_outcome
from mfi_drake.world.motion import obstacle_position
from mfi_drake.world.obstacles import obstacle_triangles

OUTCOME_WORDS = {"success": "reached", "collision": "collided", "timeout": "failed"}


def write_figure(fig: Figure, path: str, dpi: int = 110) -> None:
    """Saves `fig` to `path` (format from its extension), complete or not at
    all."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.rsplit(".", 1)[-1])


def draw_obstacles(ax, scenario: Scenario, times=(0.0,)) -> None:
    """The obstacles at times[0] and, those that move, at times[-1] too (the
    first faint) with their centre's path over `times` dashed."""
    for obstacle in scenario.obstacles:
        moving = moves(obstacle.motion)
        for t, alpha in (
            [(times[0], 0.12), (times[-1], 0.35)] if moving else [(0, 0.35)]
        ):
            ax.add_collection3d(
                Poly3DCollection(
                    obstacle_triangles(scenario, obstacle, t),
                    facecolor=(0.6, 0.6, 0.65, alpha),
                    edgecolor=(0.4, 0.4, 0.45, alpha / 2),
                    linewidth=0.3,
                )
            )
        if moving:
            centres = obstacle_position(obstacle, np.asarray(times))
            ax.plot(*centres.T, color="grey", ls="--", lw=0.8)


def draw_ground(ax, height: float) -> None:
    """A plane at z = height over the axes' x and y limits."""
    x, y = np.meshgrid(ax.get_xlim(), ax.get_ylim())
    ax.plot_surface(x, y, np.full_like(x, height), color=(0.45, 0.6, 0.4), alpha=0.25)


def _equal_box(ax, points: np.ndarray) -> None:
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, max((high - low).max() / 2, 0.5)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def plot_flights(scenario: Scenario, flights: list, path: str, title: str = "") -> None:
    """Writes the figure of one scenario flown by one or more methods."""
    fig = Figure(figsize=(13, 6))
    ax3d = fig.add_subplot(1, 2, 1, projection="3d")
    ax_len = fig.add_subplot(2, 2, 2)
    ax_err = fig.add_subplot(2, 2, 4)
    times = flights[0].times if flights else np.zeros(1)
    draw_obstacles(ax3d, scenario, times)
    start, goal = np.asarray(scenario.start), np.asarray(scenario.goal)
    corners = [start, goal]
    for obstacle in scenario.obstacles:
        corners.append(obstacle_position(obstacle, times))
    for flight in flights:
        label, colour = appearance(flight.method)
        outcome = OUTCOME_WORDS[flight_outcome(flight.metrics)]
        for k, flown in enumerate([flight, *flight.others]):
            first = k == 0  # the scenario's own vehicle; the others dashed
            style = {"color": colour, "ls": "-" if first else "--"}
            p = flown.positions
            corners.append(p)
            ax3d.plot(
                p[:, 0],
                p[:, 1],
                p[:, 2],
                lw=1.8 if first else 1.0,
                label=f"{label} ({outcome})" if first else None,
                **style,
            )
            steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
            length = np.concatenate([[0.0], np.cumsum(steps)])
            ax_len.plot(flown.times, length, label=label if first else None, **style)
            error = np.linalg.norm(p - np.asarray(flown.scenario.goal), axis=1)
            ax_err.plot(flown.times, error, label=label if first else None, **style)
    ends = [(start, goal)] + [(o.start, o.goal) for o in scenario.other_vehicles]
    for k, (a, b) in enumerate(ends):
        ax3d.scatter(
            *a, color="black", marker="o", s=40, label="start" if k == 0 else None
        )
        ax3d.scatter(
            *b,
            color="gold",
            edgecolor="black",
            marker="*",
            s=160,
            label="goal" if k == 0 else None,
        )
    _equal_box(ax3d, np.vstack([np.atleast_2d(c) for c in corners]))
    if scenario.ground is not None:
        draw_ground(ax3d, scenario.ground.height)
    ax3d.set_xlabel("x [m]")
    ax3d.set_ylabel("y [m]")
    ax3d.set_zlabel("z [m]")
    ax3d.legend(loc="upper left", fontsize=8)
    ax3d.set_title("centre-of-mass trajectory")
    ax_len.set_ylabel("path length [m]")
    ax_len.grid(alpha=0.3)
    ax_len.legend(fontsize=8)
    ax_err.set_ylabel("position error |p − p_g| [m]")
    ax_err.set_xlabel("time [s]")
    ax_err.axhline(scenario.goal_tolerance, color="grey", ls=":", lw=1)
    ax_err.grid(alpha=0.3)
    ax_len.set_xlabel("time [s]")
    fig.suptitle(title or f"{scenario.name} ({scenario.vehicle})")
    fig.tight_layout()
    write_figure(fig, path)


def write_comparison_figure(scenario: Scenario, flights: list, path: str) -> None:
    """The figure of one scenario flown by several methods."""
    names = ", ".join(appearance(f.method)[0] for f in flights)
    plot_flights(scenario, flights, path, title=f"{scenario.name}: {names}")


def plot_sweep(summary: dict, path: str) -> None:
    """Success rate and path ratio against density, one line per method."""
    fig = Figure(figsize=(11, 4.2))
    ax_s, ax_r = fig.subplots(1, 2)
    densities = [float(d) for d in summary["config"]["densities"]]
    # Methods side by side at each density, so that their bars do not hide
    # each other.
    dodge = 0.015 * (max(densities) - min(densities) or max(densities) or 1.0)
    methods = summary["methods"]
    for i, (method, pooled) in enumerate(methods.items()):
        rows = [(float(d), s) for d, s in pooled["by_density"].items() if s["n"]]
        if not rows:
            continue
        shift = dodge * (i - (len(methods) - 1) / 2)
        rows = [(x + shift, s) for x, s in rows]
        d = np.array([x for x, _ in rows])
        label, colour = appearance(method)
        rate = np.array([s["success_rate"] for _, s in rows])
        ci = np.array([s["success_rate_ci95"] for _, s in rows])
        ax_s.errorbar(
            d,
            rate,
            yerr=[rate - ci[:, 0], ci[:, 1] - rate],
            color=colour,
            marker="o",
            capsize=3,
            label=label,
        )
        ok = [(x, s) for x, s in rows if s["median_path_ratio"] is not None]
        if ok:
            dr = np.array([x for x, _ in ok])
            med = np.array([s["median_path_ratio"] for _, s in ok])
            mci = np.array([s["median_path_ratio_ci95"] for _, s in ok])
            ax_r.errorbar(
                dr,
                med,
                yerr=[med - mci[:, 0], mci[:, 1] - med],
                color=colour,
                marker="o",
                capsize=3,
                label=f"{label} median",
            )
            ax_r.plot(
                dr,
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
        ax.set_xlabel("obstacle density [obstacles / m³]")
        ax.set_xticks(densities)
        ax.set_xlim(min(densities) - 10 * dodge, max(densities) + 10 * dodge)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:  # no ratios when nothing succeeded
            ax.legend(fontsize=8)
    fig.suptitle(
        f"{summary['flights']} flights on random fields "
        f"(seed {summary['config']['seed']}, "
        f"{summary['config']['n']} fields per density)"
    )
    fig.tight_layout()
    write_figure(fig, path)
