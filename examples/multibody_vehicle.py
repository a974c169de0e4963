"""The yard of own_diagram.py flown by a MultibodyPlant vehicle.

The vehicle is a free body of the same MultibodyPlant as the world: its
shipped SDFormat model (`vehicle_model_path`) parsed by `add_vehicle_model`,
pushed by Drake's `Propeller` (QuadrotorPlant's rotor forces and moments).
`add_navigation(..., body=...)` reads the body's pose and velocity as
QuadrotorPlant's 12-state and never takes the vehicle's own collision
sphere for an obstacle. With --meshcat, Drake's Meshcat draws the yard and
the vehicle and keeps a recording to replay in the browser.

    python examples/multibody_vehicle.py [--duration 30] [--meshcat]

Prints the outcome as own_diagram.py does (the same numbers to about 1e-4 m:
the same physics on a quaternion state). Exits with status 1 on contact.
"""

import argparse
import sys

from pydrake.geometry import StartMeshcat
from pydrake.systems.framework import DiagramBuilder
from pydrake.visualization import AddDefaultVisualization

from mfi_drake import add_navigation, add_vehicle_model
from own_diagram import GOAL, fly, report, yard


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=30.0, help="s")
    parser.add_argument("--meshcat", action="store_true", help="draw the flight")
    args = parser.parse_args()

    builder = DiagramBuilder()
    plant, scene_graph = yard(builder)
    body = add_vehicle_model(plant, "drake_default")  # before Finalize
    plant.Finalize()
    handles = add_navigation(builder, plant, scene_graph, goal=GOAL, body=body)
    meshcat = None
    if args.meshcat:
        meshcat = StartMeshcat()
        AddDefaultVisualization(builder, meshcat)
        meshcat.StartRecording()
    times, log = fly(builder, handles, args.duration)
    if meshcat is not None:
        meshcat.PublishRecording()
        input(f"replay at {meshcat.web_url()}; press Enter to quit ")
    return report(times, log, handles)


if __name__ == "__main__":
    sys.exit(main())
