"""The paper's figures: the 3-D path with the obstacles (Figs 5, 7, 9, 11),
the path length and the position error over time (Figs 6, 8)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from mfi_drake.meshes import obstacle_triangles  # noqa: E402
from mfi_drake.outputs import atomic_path  # noqa: E402
from mfi_drake.scenario import Convex, Scenario, mesh_path  # noqa: E402

METHOD_COLOURS = {"mfi": "tab:blue", "apf": "tab:red", "gf": "tab:green"}
METHOD_LABELS = {"mfi": "MFI", "apf": "APF", "gf": "GF"}


def draw_obstacles(ax, scenario: Scenario) -> None:
    for obstacle in scenario.obstacles:
        mesh_file = (
            mesh_path(scenario, obstacle.shape)
            if isinstance(obstacle.shape, Convex)
            else None
        )
        triangles = obstacle_triangles(obstacle, mesh_file)
        ax.add_collection3d(
            Poly3DCollection(
                triangles,
                facecolor=(0.6, 0.6, 0.65, 0.35),
                edgecolor=(0.4, 0.4, 0.45, 0.15),
                linewidth=0.3,
            )
        )


def _equal_box(ax, points: np.ndarray) -> None:
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, max((high - low).max() / 2, 0.5)
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


def plot_flights(scenario: Scenario, flights: list, path: str, title: str = "") -> None:
    """Writes the figure of one scenario flown by one or more methods."""
    fig = plt.figure(figsize=(13, 6))
    ax3d = fig.add_subplot(1, 2, 1, projection="3d")
    ax_len = fig.add_subplot(2, 2, 2)
    ax_err = fig.add_subplot(2, 2, 4)
    draw_obstacles(ax3d, scenario)
    start, goal = np.asarray(scenario.start), np.asarray(scenario.goal)
    corners = [start, goal]
    for obstacle in scenario.obstacles:
        corners.append(np.asarray(obstacle.position))
    for flight in flights:
        colour = METHOD_COLOURS.get(flight.method)
        label = METHOD_LABELS.get(flight.method, flight.method)
        m = flight.metrics
        outcome = (
            "reached" if m["success"] else ("collided" if m["collided"] else "failed")
        )
        p = flight.positions
        corners.append(p)
        ax3d.plot(
            p[:, 0],
            p[:, 1],
            p[:, 2],
            color=colour,
            lw=1.8,
            label=f"{label} ({outcome})",
        )
        steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
        length = np.concatenate([[0.0], np.cumsum(steps)])
        ax_len.plot(flight.times, length, color=colour, label=label)
        ax_err.plot(
            flight.times, np.linalg.norm(p - goal, axis=1), color=colour, label=label
        )
    ax3d.scatter(*start, color="black", marker="o", s=40, label="start")
    ax3d.scatter(
        *goal, color="gold", edgecolor="black", marker="*", s=160, label="goal"
    )
    _equal_box(ax3d, np.vstack([np.atleast_2d(c) for c in corners]))
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
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
