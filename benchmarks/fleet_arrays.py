"""A lower bound on the cost of the other fleet design, "fleet systems"
(docs/fleets.md, Cost): one diagram and one integrator for the whole fleet,
its chain evaluated for every vehicle at once on arrays.

    python benchmarks/fleet_arrays.py [--sizes 8,16,32] [--page docs/fleets.md]

It is a measurement, not a navigator: it flies nothing. For each N it builds
N of Drake's QuadrotorPlant and one Python LeafSystem that evaluates, on
arrays over the vehicles, a reduced chain: the sphere readings of the three
nearest other vehicles, eq 11–15 with the velocity relative to each, turned
by the rule of the road, eq 12's own-pace projection, eq 16–19, eq 20 blended
in near the goal, eq 22–25 and eq 8 inverted, at the shipped defaults. It
leaves out what costs more: MFI's repairs, the delivered-force limits, the
mixer's limits, eq 21's modes and their witness functions, the scene's
obstacles and the logger. So its time for one evaluation of the diagram's
derivatives is less than a full chain's would be.

Against it, the real lone diagram's derivative with nothing in range (the
reference of fleet_scaling.py), timed the same way in the same run. The
steps one integrator would take are `fleet_scaling.shared_steps` of the
circle flown by separate integration; the lone steps, of the lone flight.
Printed, with the same number of evaluations a step on both sides: the CPU
ratio this reduced chain would reach, (lone steps × lone time × N) / (one
integrator's steps × fleet time). The target is 0.75.
"""

import argparse
import os
import sys
import time

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import Demultiplexer, Multiplexer

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import SphereSensor
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.files import write_section
from mfi_drake.flight.diagram import build_diagram, make_plant
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import OBSTACLE_COUNT, STATE_SIZE
from mfi_drake.maths.quadcopter import GRAVITY, attitude_gains, mixer_matrix
from mfi_drake.world.fleets import antipodal_circle

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fleet_scaling import alone, shared_steps  # noqa: E402

ROTORS = 4


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis (cheaper than np.cross on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], -1)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def unit(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    size = np.linalg.norm(a, axis=-1)
    return size, a / np.maximum(size, 1e-9)[..., None]


class ReducedFleetChain(LeafSystem):
    """The reduced chain of the module docstring, every vehicle at once:
    input "states" (N × 12, stacked), output "rotor_forces" (N × 4)."""

    def __init__(self, goals: np.ndarray):
        super().__init__()
        vehicle, p = VEHICLES["drake_default"], NavigatorParams()
        self._goals = np.asarray(goals, float)
        self._weight = vehicle.mass * GRAVITY
        self._radius = vehicle.collision_radius
        self._reach = SphereSensor().radius + self._radius
        self._p = p
        self._kp, self._kd = attitude_gains(vehicle, p)
        self._mix = np.linalg.inv(mixer_matrix(vehicle)).T
        self._u_max = vehicle.u_max
        turn = -np.deg2rad(RelativeVelocity().keep_right)  # right: clockwise
        self._turn = np.array(
            [
                [np.cos(turn), -np.sin(turn), 0],
                [np.sin(turn), np.cos(turn), 0],
                [0, 0, 1],
            ]
        )
        n = len(self._goals)
        self._x = self.DeclareVectorInputPort("states", STATE_SIZE * n)
        self.DeclareVectorOutputPort("rotor_forces", ROTORS * n, self._calc)

    def _calc(self, context, output):
        x = self._x.Eval(context).reshape(-1, STATE_SIZE)
        output.SetFromVector(self.rotor_forces(x).ravel())

    def obstacle_force(self, x: np.ndarray) -> np.ndarray:
        """(N, 3): eq 11–15 summed over each vehicle's nearest others, with
        the relative velocity turned by the rule, made ⟂ v (the own pace)."""
        p, n = self._p, len(x)
        position, v = x[:, 0:3], x[:, 6:9]
        _, l_a = unit(v)
        k = min(OBSTACLE_COUNT, n - 1)
        if not k:
            return np.zeros((n, 3))
        d = position[None, :, :] - position[:, None, :]  # to every other
        centre = np.linalg.norm(d, axis=2) + np.diag(np.full(n, np.inf))
        near = np.argpartition(centre, k - 1, axis=1)[:, :k]
        gap = np.take_along_axis(centre, near, 1) - self._radius
        r_o = np.take_along_axis(d, near[..., None], 1)
        r_o = r_o * (gap / (gap + self._radius))[..., None]
        seen = gap < self._reach - self._radius
        relative = (v[:, None, :] - v[near]) @ self._turn.T
        rel_speed, l_r = unit(relative)
        size, normal = unit(r_o)
        r = np.maximum(size - self._radius, p.min_distance)
        l_o = l_r - dot(l_r, normal)[..., None] * normal  # eq 11
        f = np.where(seen & (r < p.r_l), p.c * rel_speed / r, 0.0)  # eq 13
        f_a = np.where(seen & (r < p.r_b), p.c_perp * (1 / r - 1 / p.r_b) / r**2, 0)
        F = cross(l_r, cross(l_o, l_r)) * f[..., None]  # eq 12
        F = F + cross(l_r, cross(l_o, normal)) * f_a[..., None]  # eq 14
        F_o = F.sum(1)
        return F_o - dot(F_o, l_a)[:, None] * l_a  # the own pace

    def rotor_forces(self, x: np.ndarray) -> np.ndarray:
        """(N, 4): the rotor forces of the whole reduced chain."""
        p = self._p
        position, attitude, v, rates = x[:, 0:3], x[:, 3:6], x[:, 6:9], x[:, 9:12]
        speed, l_a = unit(v)
        F_o = self.obstacle_force(x)
        to_goal, l_g = unit(self._goals - position)
        F_gc = p.K_omega * cross(cross(l_a, l_g), v)  # eq 16–18, small turns
        F_v = -p.K_v * (speed - p.v_d)[:, None] * l_a  # eq 19
        F_pd = p.K_P * (self._goals - position) - p.K_D * v  # eq 20
        cruise = np.clip((to_goal - p.r_gl) / p.r_gl, 0.0, 1.0)[:, None]
        F_n = F_o + cruise * (F_gc + F_v) + (1.0 - cruise) * F_pd
        T = F_n[:, 2] + self._weight  # eq 22–24
        c, s = np.cos(attitude[:, 2]), np.sin(attitude[:, 2])
        f_x, f_y = p.K_Pv * F_n[:, 0], p.K_Pv * F_n[:, 1]
        desired = np.stack([-(-s * f_x + c * f_y) / T, (c * f_x + s * f_y) / T], 1)
        error = attitude.copy()
        error[:, :2] -= desired
        torque = -(self._kp * error + self._kd * rates)  # eq 25
        command = np.concatenate([T[:, None], torque], 1)
        return np.clip(command @ self._mix, 0.0, self._u_max)  # eq 8


def fleet_diagram(scene) -> tuple:
    """(the diagram of N plants and the reduced chain, a mid-flight state)."""
    ends = [(scene.start, scene.goal)]
    ends += [(other.start, other.goal) for other in scene.other_vehicles]
    n, vehicle = len(ends), VEHICLES["drake_default"]
    builder = DiagramBuilder()
    states = builder.AddSystem(Multiplexer([STATE_SIZE] * n))
    forces = builder.AddSystem(Demultiplexer([ROTORS] * n))
    chain = builder.AddSystem(ReducedFleetChain(np.array([g for _, g in ends])))
    for i in range(n):
        plant = builder.AddSystem(make_plant(vehicle))
        builder.Connect(plant.get_output_port(0), states.get_input_port(i))
        builder.Connect(forces.get_output_port(i), plant.get_input_port(0))
    builder.Connect(states.get_output_port(0), chain.get_input_port(0))
    builder.Connect(chain.get_output_port(0), forces.get_input_port(0))
    x = np.zeros((n, STATE_SIZE))
    rng = np.random.default_rng(0)  # near the middle, moving: everyone in range
    for i, (start, goal) in enumerate(ends):
        x[i, 0:3] = (np.asarray(start) + np.asarray(goal)) / 2 + rng.normal(0, 0.5, 3)
        x[i, 6:9] = rng.normal(0.0, 0.7, 3)
    return builder.Build(), x.ravel()


def derivative_time(diagram, x: np.ndarray, repeats: int = 1000) -> float:
    """CPU seconds for one evaluation of the diagram's derivatives (best of
    5 rounds; the state changes between evaluations, so nothing is cached)."""
    context = diagram.CreateDefaultContext()
    derivatives = diagram.AllocateTimeDerivatives()
    states = [x + 1e-9 * k for k in range(8)]
    best = np.inf
    for _ in range(5):
        start = time.process_time()
        for k in range(repeats):
            context.SetContinuousState(states[k % 8])
            diagram.CalcTimeDerivatives(context, derivatives)
        best = min(best, (time.process_time() - start) / repeats)
    return best


def lone_derivative_time(scene) -> float:
    """The real lone diagram's derivative time, halfway, nothing in range."""
    flight = build_diagram(scene)
    context = flight.diagram.CreateDefaultContext()
    x = np.zeros(STATE_SIZE)
    x[0:3] = (np.asarray(scene.start) + np.asarray(scene.goal)) / 2
    x[6:9] = np.asarray(scene.goal) - np.asarray(scene.start)
    x[6:9] /= np.linalg.norm(x[6:9])  # cruising at 1 m/s
    flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(x)
    return derivative_time(
        flight.diagram, context.get_continuous_state_vector().CopyToVector()
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="8,16,32")
    parser.add_argument("--page", help="a page to write the table into (fleet_arrays)")
    args = parser.parse_args(argv)
    lines = [
        f"load average {os.getloadavg()[0]:.1f} at the start:",
        "",
        "| N | one integrator's steps (est.) | lone steps "
        "| lone chain [µs a derivative] | reduced fleet chain [µs a derivative] "
        "| a vehicle [µs] | CPU ratio it would reach |",
        "|---|---|---|---|---|---|---|",
    ]
    for n in [int(s) for s in args.sizes.split(",") if s]:
        scene = antipodal_circle(n)
        lone = alone(scene)
        lone_steps = simulate(lone).metrics["steps"]
        fleet = simulate(scene)
        steps = shared_steps([fleet, *fleet.others], fleet.metrics["sim_time"])
        t_lone = lone_derivative_time(lone)
        t_fleet = derivative_time(*fleet_diagram(scene))
        ratio = lone_steps * t_lone * n / (steps * t_fleet)
        lines.append(
            f"| {n} | {steps} | {lone_steps} | {1e6 * t_lone:.0f} "
            f"| {1e6 * t_fleet:.0f} | {1e6 * t_fleet / n:.1f} | {ratio:.2f} |"
        )
        print(lines[-1], flush=True)
    if args.page:
        write_section(args.page, "fleet_arrays", "\n".join(lines))


if __name__ == "__main__":
    main()
