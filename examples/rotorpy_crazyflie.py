"""MFI inside rotorpy: rotorpy's Crazyflie, with rotorpy's own dynamics
(its rotor drag, induced inflow and motor lag), flies among the blocks of a
rotorpy World to a goal, MFI as its controller
(`mfi_drake.adapters.rotorpy.RotorpyController`). Then the same world,
vehicle and goal flown in mfi_drake's own simulation, for the mismatch.

    pip install 'mfi_drake[rotorpy]'
    python examples/rotorpy_crazyflie.py [--duration 60]

Prints each flight's outcome, least clearance and path length; exits with
status 1 unless rotorpy's flight reaches the goal without contact.
"""

import argparse
import os
import sys

os.environ.setdefault("MPLBACKEND", "Agg")  # rotorpy's plotter, never shown

import numpy as np
from rotorpy.environments import Environment
from rotorpy.simulate import ExitStatus
from rotorpy.trajectories.hover_traj import HoverTraj
from rotorpy.vehicles.crazyflie_params import quad_params
from rotorpy.vehicles.multirotor import Multirotor
from rotorpy.world import World

from mfi_drake import simulate
from mfi_drake.adapters.rotorpy import RotorpyController, vehicle_from_quad_params
from mfi_drake.config.scenario import Box, Obstacle, Scenario, SphereSensor

START, GOAL = np.array([0.0, 0.0, 1.0]), np.array([1.5, 0.0, 1.0])
BLOCKS = [  # [x_min, x_max, y_min, y_max, z_min, z_max] [m]: two pillars
    [0.4, 0.52, -0.25, 0.1, 0.0, 2.0],
    [0.9, 1.02, -0.05, 0.3, 0.0, 2.0],
]
WORLD = {
    "bounds": {"extents": [-1.0, 3.0, -2.0, 2.0, 0.0, 2.0]},
    "blocks": [{"extents": b, "color": [1, 0, 0]} for b in BLOCKS],
}
SENSOR_RADIUS = 3.0  # m
GOAL_TOLERANCE = 0.05  # m, and 5 cm/s: arrived


def path_metrics(world: World, radius: float, positions: np.ndarray):
    """(least clearance of the collision sphere, path length) [m]."""
    _, distances = world.closest_points(positions)
    length = float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1)))
    return float(distances.min() - radius), length


def fly_rotorpy(duration: float):
    world = World(WORLD)
    controller = RotorpyController(
        GOAL, world, quad_params, sensor_radius=SENSOR_RADIUS
    )
    vehicle = controller.vehicle
    initial = {
        "x": START.copy(),
        "v": np.zeros(3),
        "q": np.array([0.0, 0.0, 0.0, 1.0]),
        "w": np.zeros(3),
        "wind": np.zeros(3),
        "rotor_speeds": np.full(4, np.sqrt(vehicle.hover_command)),
    }

    def arrived(t, state):
        near = np.linalg.norm(state["x"] - GOAL) < GOAL_TOLERANCE
        if near and np.linalg.norm(state["v"]) < 0.05:
            return ExitStatus.COMPLETE
        return None

    environment = Environment(
        vehicle=Multirotor(quad_params, initial_state=initial, aero=True),
        controller=controller,
        trajectory=HoverTraj(x0=GOAL),
        world=world,
        sim_rate=100,
        safety_margin=vehicle.collision_radius,
    )
    result = environment.run(t_final=duration, terminate=arrived)
    positions = result["state"]["x"]
    clearance, length = path_metrics(world, vehicle.collision_radius, positions)
    reached = result["exit"] == ExitStatus.COMPLETE
    return reached, float(result["time"][-1]), clearance, length


def fly_mfi_drake(duration: float):
    """The same world in mfi_drake: its blocks as boxes, the vehicle of the
    same quad_params (no rotor drag; the motor lag on u = ω²)."""
    vehicle = vehicle_from_quad_params(quad_params)
    boxes = [
        Obstacle(
            shape=Box(size=[b[1] - b[0], b[3] - b[2], b[5] - b[4]]),
            position=[(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2],
        )
        for b in BLOCKS
    ]
    scenario = Scenario(
        name="rotorpy_world",
        start=START.tolist(),
        goal=GOAL.tolist(),
        duration=duration,
        vehicle=vehicle,
        sensor=SphereSensor(radius=SENSOR_RADIUS),
        obstacles=boxes,
        goal_tolerance=GOAL_TOLERANCE,
    )
    m = simulate(scenario, "mfi", until_settled=True).metrics
    return m["reached"], m["convergence_time"], m["min_clearance"], m["path_length"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="s")
    args = parser.parse_args()
    outcomes = {}
    for name, fly in (("rotorpy", fly_rotorpy), ("mfi_drake", fly_mfi_drake)):
        reached, t, clearance, length = outcomes[name] = fly(args.duration)
        print(
            f"{name}: {'reached' if reached else 'did not reach'} the goal at "
            f"t = {t:.2f} s, least clearance {clearance:.3f} m, "
            f"path length {length:.3f} m"
        )
    (_, _, c_r, l_r), (_, _, c_m, l_m) = outcomes["rotorpy"], outcomes["mfi_drake"]
    print(f"mismatch: clearance {c_r - c_m:+.3f} m, path length {l_r - l_m:+.3f} m")
    reached, _, clearance, _ = outcomes["rotorpy"]
    return 0 if reached and clearance > 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
