"""The Pelican figures of docs/depth_camera.md (paper §VI-B, Fig 10b and 11).

    python docs/pelican_figures.py

Writes to docs/figures/:
- pelican_cylinder.png, pelican_cube.png: the Fig 11 flights, depth camera
  as the only sensor;
- pelican_side_goal.png: scenarios/pelican_side_goal.yaml flown with the yaw
  held at 0 (the paper) and with yaw_follows_motion;
- pelican_depth_view.png: what the camera sees at the start of the cylinder
  flight, with the closest point marked (cf. Fig 10b).
Prints each flight's one-line summary.
"""

import dataclasses
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from mfi_drake.app.figures import plot_flights  # noqa: E402
from mfi_drake.app.flight_commands import summary_line  # noqa: E402
from mfi_drake.files import atomic_path  # noqa: E402
from mfi_drake.flight.diagram import build_diagram  # noqa: E402
from mfi_drake.flight.simulation import simulate  # noqa: E402
from mfi_drake.systems.camera import camera_info  # noqa: E402
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIGURES = os.path.join(ROOT, "docs", "figures")


def scenario_path(name: str) -> str:
    return os.path.join(ROOT, "scenarios", f"{name}.yaml")


def fig11() -> None:
    for name in ("pelican_cylinder", "pelican_cube"):
        scenario = load_scenario(scenario_path(name))
        flight = simulate(scenario)
        print(summary_line(flight.metrics))
        plot_flights(
            scenario,
            [flight],
            os.path.join(FIGURES, f"{name}.png"),
            title=f"{name}: Pelican, depth camera only (paper Fig 11)",
        )


def side_goal() -> None:
    scenario = load_scenario(scenario_path("pelican_side_goal"))
    flights = []
    for follows in (False, True):
        scenario.navigator.yaw_follows_motion = follows
        flight = simulate(scenario)
        print(f"yaw_follows_motion={follows}: {summary_line(flight.metrics)}")
        # The label plot_flights shows is the method's name.
        label = "yaw follows motion" if follows else "yaw held at 0"
        flights.append(dataclasses.replace(flight, method=label))
    plot_flights(
        scenario,
        flights,
        os.path.join(FIGURES, "pelican_side_goal.png"),
        title="pelican_side_goal: goal to the camera's side",
    )


def depth_view() -> None:
    scenario = load_scenario(scenario_path("pelican_cylinder"))
    flight = build_diagram(scenario)
    context = flight.diagram.CreateDefaultContext()
    x = np.zeros(12)
    x[0:3] = scenario.start
    flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(x)
    cloud = flight.diagram.GetSubsystemByName("point_cloud_0")
    xyz = cloud.point_cloud_output_port().Eval(cloud.GetMyContextFromRoot(context))
    # The camera sits at the vehicle centre here, so the distance of each
    # return from the camera is its distance from the vehicle: its minimum is
    # the closest point r_o the navigator gets.
    info = camera_info(scenario.sensor)
    distance = np.linalg.norm(xyz.xyzs(), axis=0).reshape(info.height(), info.width())
    closest = np.unravel_index(
        np.argmin(np.where(np.isfinite(distance), distance, np.inf)), distance.shape
    )
    fig, ax = plt.subplots(figsize=(6, 4.2))
    image = ax.imshow(np.ma.masked_invalid(distance), cmap="viridis_r")
    ax.plot(closest[1], closest[0], "r+", ms=14, mew=2, label="closest point")
    fig.colorbar(image, ax=ax, label="distance [m] (blank: no return)")
    ax.set_title(f"depth camera at the start of {scenario.name}")
    ax.set_xlabel("u [pixel]")
    ax.set_ylabel("v [pixel]")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    with atomic_path(os.path.join(FIGURES, "pelican_depth_view.png")) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


if __name__ == "__main__":
    fig11()
    side_goal()
    depth_view()
