"""MFI in your own Drake diagram.

Your world is an SDFormat file (examples/yard.sdf: a wall, a post and a
boulder) parsed by Drake's Parser into the plant and SceneGraph of
`AddMultibodyPlantSceneGraph`; your vehicle is Drake's QuadrotorPlant;
your Simulator runs it. `add_navigation` adds the sensor (reading every
proximity geometry of your SceneGraph), MFI's navigator, the attitude PD,
the mixer and a logger; `apply_simulator_config` is the one line a plain
Simulator needs (eq 21's mode switches are witness functions).

    python examples/own_diagram.py [--duration 30]

Prints the outcome read from the log: the distance to the goal and the
least clearance the sensor read. Exits with status 1 on contact.
"""

import argparse
import pathlib
import sys

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from mfi_drake import (
    NavigationHandles,
    add_navigation,
    apply_simulator_config,
    default_simulator_config,
)

WORLD = pathlib.Path(__file__).parent / "yard.sdf"
START, GOAL = [0.0, 0.0, 1.5], [12.0, 0.0, 1.5]


def yard(builder: DiagramBuilder):
    """The world: yard.sdf's welded links, their collision geometry in the
    SceneGraph. Returns the (unfinalized) plant and the SceneGraph."""
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModels(str(WORLD))
    return plant, scene_graph


def fly(builder: DiagramBuilder, handles: NavigationHandles, duration: float):
    """Builds the diagram, flies it from START for `duration` s in a plain
    Simulator and returns `handles.read_log`'s (times, log)."""
    simulator = Simulator(builder.Build())
    apply_simulator_config(default_simulator_config(), simulator)  # the one line
    context = simulator.get_mutable_context()
    handles.set_start(context, START)
    simulator.AdvanceTo(duration)
    return handles.read_log(context)


def report(times: np.ndarray, log: dict, handles: NavigationHandles) -> int:
    """Prints the outcome; 0 without contact, else 1."""
    errors = np.linalg.norm(log["state"][:, :3] - GOAL, axis=1)
    error = errors[-1]
    # Each reading is [r_o (3), seen (1)]: r_o points from the vehicle's
    # centre to an obstacle's closest point (within the sensor's radius).
    readings = log["obstacle"].reshape(len(times), -1, 4)
    seen = readings[..., 3] > 0.5
    nearest = np.linalg.norm(readings[..., :3], axis=2)[seen].min()
    clearance = nearest - handles.vehicle.collision_radius
    if error < 0.1:
        since = times[np.flatnonzero(errors >= 0.1)[-1] + 1]  # stays within since
        outcome = f"reached the goal at t = {since:.2f} s"
    else:
        outcome = "did not reach the goal"
    print(
        f"{outcome}: {len(times)} steps to t = {times[-1]:.2f} s, distance to "
        f"the goal {error:.3f} m, least clearance {clearance:.3f} m"
    )
    return 0 if clearance > 0.0 else 1


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=30.0, help="s")
    args = parser.parse_args()

    builder = DiagramBuilder()
    plant, scene_graph = yard(builder)
    plant.Finalize()
    quadrotor = builder.AddSystem(QuadrotorPlant())
    handles = add_navigation(builder, quadrotor, scene_graph, goal=GOAL)
    times, log = fly(builder, handles, args.duration)
    return report(times, log, handles)


if __name__ == "__main__":
    sys.exit(main())
