"""MFI as a rotorpy controller (docs/vehicles.md, "MFI inside rotorpy").

`RotorpyController(goal, world, quad_params)` is what rotorpy's
`Environment` or `simulate` calls where it would call its `SE3Control`:
`update(t, state, flat_output)` returns the same control dict. It reads
each of the world's blocks' closest point to the vehicle from rotorpy's own
`World.closest_points` (one World a block, so that every obstacle is read,
not only the nearest) and the faces of its bounds (leaving them is a
collision in rotorpy), turns rotorpy's state into QuadrotorPlant's
12-vector and calls `NavigationStep` with the vehicle `vehicle_from_quad_params`
builds from the same quad_params rotorpy flies. The trajectory's flat
outputs are not read: the goal is fixed, the path is MFI's.

Needs rotorpy (`pip install 'mfi_drake[rotorpy]'`); nothing here imports
it, the caller hands its `World` and quad_params in.
"""

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix

from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.step import NavigationStep
from mfi_drake.maths.constants import GRAVITY
from mfi_drake.maths.quadcopter import mixer_matrix, rotor_xy


def vehicle_from_quad_params(quad_params: dict, name: str = "rotorpy") -> Vehicle:
    """The `Vehicle` of rotorpy's quad_params: mass, principal inertia (Izz
    held to Ixx + Iyy, the bound any body's moments keep: the Crazyflie's
    published 2.89e-5 exceeds it by 1 %), arm length the mean distance of
    the rotors from the centre, their layout from their places, kF = k_eta
    and kM = k_m per (rad/s)², u_max the squared top rotor speed, the motor
    time constant tau_m; rotor_radius where given, else half the arm (the
    Crazyflie's 2.25 cm propellers on a 4.3 cm arm)."""
    xy = np.array([quad_params["rotor_pos"][k][:2] for k in quad_params["rotor_pos"]])
    if len(xy) != 4:
        raise ValueError(f"quad_params: {len(xy)} rotors, not 4")
    arm = float(np.mean(np.hypot(xy[:, 0], xy[:, 1])))
    angles = np.degrees(np.arctan2(xy[:, 1], xy[:, 0])) % 90.0
    layout = "x" if np.all(np.abs(angles - 45.0) < 5.0) else "+"
    Ixx, Iyy = float(quad_params["Ixx"]), float(quad_params["Iyy"])
    return as_vehicle(
        Vehicle(
            name=name,
            mass=float(quad_params["mass"]),
            arm_length=arm,
            inertia=[Ixx, Iyy, min(float(quad_params["Izz"]), Ixx + Iyy)],
            kF=float(quad_params["k_eta"]),
            kM=float(quad_params["k_m"]),
            u_max=float(quad_params["rotor_speed_max"]) ** 2,
            rotor_radius=float(quad_params.get("rotor_radius", arm / 2.0)),
            motor_time_constant=float(quad_params.get("tau_m", 0.0)),
            layout=layout,
        )
    )


def rotor_order(vehicle: Vehicle, quad_params: dict) -> list[int]:
    """For each of rotorpy's rotors (its rotor_pos order), the index of the
    vehicle's rotor at the same place (`quadcopter.rotor_xy`)."""
    ours = rotor_xy(vehicle.arm_length, vehicle.layout)
    order = []
    for key in quad_params["rotor_pos"]:
        place = np.asarray(quad_params["rotor_pos"][key][:2], float)
        order.append(int(np.argmin(np.linalg.norm(ours - place, axis=1))))
    if sorted(order) != [0, 1, 2, 3]:
        raise ValueError("quad_params: its rotors do not sit at the layout's places")
    return order


def plant_state(state: dict) -> np.ndarray:
    """QuadrotorPlant's 12-vector (x, rpy, ẋ, rpẏ) of rotorpy's state dict
    (x, v, q = [i, j, k, w] body to world, w the body rates)."""
    i, j, k, w = np.asarray(state["q"], float)
    q = np.array([w, i, j, k])
    rpy = RollPitchYaw(RotationMatrix(Quaternion(q / np.linalg.norm(q))))
    rates = rpy.CalcRpyDtFromAngularVelocityInChild(np.asarray(state["w"], float))
    return np.concatenate([state["x"], rpy.vector(), state["v"], rates]).astype(float)


class RotorpyController:
    """MFI (or `method`: any name `NavigationStep` takes) flying rotorpy's
    vehicle of `quad_params` to `goal` [x, y, z] (m) among the blocks of
    rotorpy's `world`, sensed within `sensor_radius` (m). The gains are
    the vehicle's (`config.vehicle_gains`)."""

    def __init__(
        self, goal, world, quad_params: dict, method="mfi", sensor_radius: float = 3.0
    ):
        self.vehicle = vehicle_from_quad_params(quad_params)
        self.navigation = NavigationStep(
            goal, method, vehicle=self.vehicle, sensor_radius=sensor_radius
        )
        self._params = for_vehicle(self.navigation.scenario.navigator, self.vehicle)
        self.goal = np.asarray(goal, float)
        self._order = rotor_order(self.vehicle, quad_params)
        self._mixer = mixer_matrix(self.vehicle)
        world_class = type(world)
        bounds = world.world.get("bounds")
        # rotorpy counts leaving its bounds a collision: its six faces are
        # obstacles too (None: a world without bounds).
        self._bounds = None if bounds is None else np.array(bounds["extents"], float)
        # One World a block: `closest_points` answers the nearest block only.
        self._blocks = [
            world_class({"bounds": bounds, "blocks": [block]})
            for block in world.world.get("blocks", [])
        ]

    def closest_points(self, position: np.ndarray) -> np.ndarray:
        """Each block's closest point to `position`, by rotorpy's
        `World.closest_points`, then the closest point of each face of the
        world's bounds (k × 3)."""
        p = np.asarray(position, float).reshape(1, 3)
        points = [block.closest_points(p)[0][0] for block in self._blocks]
        if self._bounds is not None:
            low, high = self._bounds[0::2], self._bounds[1::2]
            inside = np.clip(p[0], low, high)
            for axis in range(3):
                for side in (low, high):
                    face = inside.copy()
                    face[axis] = side[axis]
                    points.append(face)
        return np.array(points).reshape(-1, 3)

    def update(self, t: float, state: dict, flat_output: dict) -> dict:
        """rotorpy's controller call: the control dict of its SE3Control
        (cmd_motor_speeds [rad/s] and cmd_motor_thrusts [N] in rotorpy's
        rotor order, cmd_thrust [N], cmd_moment [N·m], cmd_q the attitude
        setpoint [i, j, k, w], cmd_w 0 (MFI commands no body rates), cmd_v
        the velocity F_n would reach over the attitude loop's lag, cmd_acc
        the mass-normalised thrust vector F_n/m + g e_z) from MFI's chain;
        `flat_output` is not read."""
        x = plant_state(state)
        out = self.navigation.step(x, self.closest_points(x[:3]), t)
        u = np.asarray(out.propeller_force, float)[self._order]
        m = self.vehicle.mass
        thrust_torque = self._mixer @ out.propeller_force
        roll, pitch, yaw = out.attitude_setpoint[1:4]
        q = RotationMatrix(RollPitchYaw(roll, pitch, yaw)).ToQuaternion()
        lag = 2.0 * self._params.attitude_damping_ratio
        lag /= self._params.attitude_natural_frequency
        acceleration = out.navigation_force / m
        return {
            "cmd_motor_speeds": np.sqrt(np.maximum(u, 0.0)),
            "cmd_motor_thrusts": self.vehicle.kF * u,
            "cmd_thrust": float(thrust_torque[0]),
            "cmd_moment": thrust_torque[1:4].copy(),
            "cmd_q": np.array([q.x(), q.y(), q.z(), q.w()]),
            "cmd_w": np.zeros(3),
            "cmd_v": np.asarray(state["v"], float) + lag * acceleration,
            "cmd_acc": acceleration + np.array([0.0, 0.0, GRAVITY]),
        }
