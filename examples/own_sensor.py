"""MFI's controller around your own sensor.

No SceneGraph here: your perception knows the three spheres of
step_loop.py in closed form. It is a LeafSystem with an input "state" (the
12-vector; `add_controller` connects it to the state estimate) and an
output "obstacle", the signal MFI's navigator reads: 3 readings
[r_o (3), seen (1)], nearest first, r_o the vector from the vehicle's
centre to an obstacle's closest point, seen = 1 within the sensor's radius
(else the reading is zeros). `add_controller` adds the navigator, the goal
attraction, the attitude PD and the mixer from QuadrotorPlant's state to
its rotor forces; a `NavigationConfig` holds its goal and parameters.

    python examples/own_sensor.py [--duration 30]

Prints the outcome (as step_loop.py does for its sampled loop); exits with
status 1 if the goal was not reached or on contact.
"""

import argparse
import sys

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput

from mfi_drake import (
    NavigationConfig,
    add_controller,
    apply_simulator_config,
    default_simulator_config,
)
from step_loop import GOAL, GOAL_TOLERANCE, START, clearance, closest_points

RANGE = 3.0  # [m] the sensor's radius r_s


class KnownSpheres(LeafSystem):
    """Your sensor: the spheres' closest points, as MFI's "obstacle" signal."""

    def __init__(self):
        super().__init__()
        state = self.DeclareVectorInputPort("state", 12)
        self.DeclareVectorOutputPort(
            "obstacle", 12, self._calc, prerequisites_of_calc={state.ticket()}
        )

    def _calc(self, context, output):
        p = self.get_input_port().Eval(context)[:3]
        r_o = closest_points(p) - p
        distances = np.linalg.norm(r_o, axis=1)
        readings = [
            np.append(r_o[i], 1.0) if distances[i] <= RANGE else np.zeros(4)
            for i in np.argsort(distances)  # nearest first
        ]
        output.SetFromVector(np.concatenate(readings))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=30.0, help="s")
    args = parser.parse_args()

    builder = DiagramBuilder()
    quadrotor = builder.AddSystem(QuadrotorPlant())
    sensor = builder.AddSystem(KnownSpheres())
    add_controller(
        builder,
        NavigationConfig(goal=GOAL),  # the goal, the vehicle, MFI's parameters
        quadrotor.get_output_port(0),
        sensor,
        quadrotor.get_input_port(0),
    )
    states = LogVectorOutput(quadrotor.get_output_port(0), builder, 0.0)
    simulator = Simulator(builder.Build())
    apply_simulator_config(default_simulator_config(), simulator)
    context = simulator.get_mutable_context()
    start = np.zeros(12)
    start[:3] = START
    quadrotor.GetMyMutableContextFromRoot(context).SetContinuousState(start)
    simulator.AdvanceTo(args.duration)

    path = states.FindLog(context).data()[:3].T  # one column per step
    least = min(clearance(p) for p in path)
    error = np.linalg.norm(path[-1] - GOAL)
    reached = error < GOAL_TOLERANCE
    print(
        f"{'reached' if reached else 'did not reach'} the goal: "
        f"t = {context.get_time():.2f} s, final error {error:.3f} m, "
        f"least clearance {least:.3f} m"
    )
    return 0 if reached and least > 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
