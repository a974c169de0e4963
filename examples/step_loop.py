"""MFI in a plain control loop, as a flight stack would run it.

A flight stack (a ROS 2 node, a PX4 offboard loop) has its own state
estimate and its own perception, and calls the navigation at its own rate.
Here the loop is plain Python: every 10 ms it hands `NavigationStep` the
vehicle's state and the closest point of each sphere, and holds the rotor
forces it returns while Drake's QuadrotorPlant dynamics are integrated with
fixed-step RK4 (no Simulator).

    python examples/step_loop.py [--duration 30] [--rate 100]

Prints the outcome; exits with status 1 if the goal was not reached.
"""

import argparse
import sys

import numpy as np
from pydrake.examples import QuadrotorPlant

from mfi_drake import NavigationStep

START, GOAL = [0.0, 0.0, 1.5], [10.0, 0.0, 1.5]
SPHERES = [  # (centre [m], radius [m])
    ([3.0, 0.1, 1.5], 0.8),
    ([6.0, -0.5, 1.5], 0.7),
    ([8.0, 0.9, 1.3], 0.5),
]
COLLISION_RADIUS = 0.225  # drake_default: arm 0.15 m + rotor 0.075 m
GOAL_TOLERANCE = 0.1  # [m]
SUBSTEPS = 10  # RK4 steps per control period


def closest_points(p: np.ndarray) -> np.ndarray:
    """What perception gives: each sphere's surface point closest to p."""
    points = []
    for centre, radius in SPHERES:
        away = p - np.asarray(centre)
        points.append(centre + radius * away / np.linalg.norm(away))
    return np.array(points)


def clearance(p: np.ndarray) -> float:
    """The least gap between the vehicle's collision sphere and a sphere."""
    return min(
        np.linalg.norm(p - np.asarray(c)) - r - COLLISION_RADIUS for c, r in SPHERES
    )


def rk4(plant, context, x: np.ndarray, u: np.ndarray, h: float) -> np.ndarray:
    """One RK4 step of the plant's dynamics with the rotor forces u held."""
    plant.get_input_port(0).FixValue(context, u)

    def f(state):
        context.SetContinuousState(state)
        return plant.EvalTimeDerivatives(context).CopyToVector()

    k1 = f(x)
    k2 = f(x + 0.5 * h * k1)
    k3 = f(x + 0.5 * h * k2)
    k4 = f(x + h * k3)
    return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=30.0, help="s")
    parser.add_argument("--rate", type=float, default=100.0, help="Hz")
    args = parser.parse_args()

    plant = QuadrotorPlant()  # Drake's defaults are the drake_default vehicle
    context = plant.CreateDefaultContext()
    navigation = NavigationStep(GOAL, method="mfi", vehicle="drake_default")
    x = np.zeros(12)
    x[:3] = START
    period = 1.0 / args.rate
    least, mode, t = np.inf, None, 0.0
    for k in range(int(round(args.duration * args.rate))):
        t = k * period
        p = x[:3]
        least = min(least, clearance(p))
        if np.linalg.norm(p - GOAL) < GOAL_TOLERANCE and np.linalg.norm(x[6:9]) < 0.05:
            break
        out = navigation.step(x, closest_points(p), t)
        if out.mode != mode:
            name = "cruise" if out.mode else "PD"
            print(f"t = {t:6.2f} s: eq 21 mode {name}, at {np.round(p, 2)}")
            mode = out.mode
        for _ in range(SUBSTEPS):
            x = rk4(plant, context, x, out.propeller_force, period / SUBSTEPS)
    error = np.linalg.norm(x[:3] - GOAL)
    reached = error < GOAL_TOLERANCE
    print(
        f"{'reached' if reached else 'did not reach'} the goal: t = {t:.2f} s, "
        f"final error {error:.3f} m, least clearance {least:.3f} m"
    )
    return 0 if reached and least > 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
