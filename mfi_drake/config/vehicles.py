"""Vehicles: the `Vehicle` record mapped onto Drake's QuadrotorPlant(m, L,
I, kF, kM), its presets, its checks, and `as_vehicle`, which every entry
point calls on what a user gives as `vehicle` (docs/vehicles.md).

Drake's plant takes four inputs u_i ≥ 0; rotor i pushes kF·u_i and twists
kM·u_i. For `drake_default` u_i is a force in newtons (kF = 1). For `pelican`
u_i is the squared rotor speed ω_i² [(rad/s)²], so kF is RotorS' motor
constant and kM = kF · moment constant.
"""

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from mfi_drake.maths.constants import GRAVITY

LAYOUTS = ("+", "x")  # rotors on the body axes (QuadrotorPlant's) or between
MIN_THRUST_TO_WEIGHT = 1.2  # below it the tilt limit and the torques starve


@dataclass
class Vehicle:
    """A quadrotor (YAML `!Vehicle {...}`). Every field without a default
    below 0 must be given; `as_vehicle` checks them (`vehicle_problems`)."""

    name: str = "custom"
    mass: float = 0.0  # kg
    arm_length: float = 0.0  # m, centre to rotor axis (the plant's L)
    inertia: list[float] = field(default_factory=list)  # kg·m², Ixx, Iyy, Izz
    kF: float = 0.0  # N per unit of u
    kM: float = 0.0  # N·m per unit of u
    u_max: float = 0.0  # largest rotor command (the saturation of the mixer)
    rotor_radius: float = 0.0  # m
    # s: each rotor follows its command through a first-order lag (0: at once).
    motor_time_constant: float = 0.0
    # "+": rotor k at arm_length along +x, +y, −x, −y (QuadrotorPlant's);
    # "x": at 45°, 135°, 225°, 315° (`maths.quadcopter.rotor_angles`).
    layout: str = "+"

    def __post_init__(self):
        # A tuple: the record is compared, copied and compiled (`compiled.record`).
        self.inertia = tuple(self.inertia)

    @property
    def collision_radius(self) -> float:
        """Radius of the sphere that holds the arms and rotors [m].

        Every obstacle is grown by it: the navigator's r and the reported
        clearance are distances from this sphere, not from the centre.
        """
        return self.arm_length + self.rotor_radius

    @property
    def weight(self) -> float:
        return self.mass * GRAVITY

    @property
    def hover_command(self) -> float:
        """u_i that holds the vehicle still."""
        return self.weight / (4.0 * self.kF)

    @property
    def thrust_to_weight(self) -> float:
        """4 kF u_max / (m g): the most thrust over the weight."""
        return 4.0 * self.kF * self.u_max / self.weight

    def inertia_matrix(self) -> np.ndarray:
        return np.diag(self.inertia)


VEHICLES: dict[str, Vehicle] = {
    # QuadrotorPlant's own defaults; a rotor pushes at most 4 N (thrust to
    # weight ≈ 2.1), its 5-inch propeller has radius 0.075 m.
    "drake_default": Vehicle(
        name="drake_default",
        mass=0.775,
        arm_length=0.15,
        inertia=(0.0015, 0.0025, 0.0035),
        kF=1.0,
        kM=0.0245,
        u_max=4.0,
        rotor_radius=0.075,
    ),
    # AscTec Pelican as RotorS describes it: motor constant 9.9865e-6
    # N/(rad/s)², moment constant 0.016 m, 838 rad/s at most (7.0 N a rotor,
    # thrust to weight ≈ 2.9), 10-inch propellers.
    "pelican": Vehicle(
        name="pelican",
        mass=1.0,
        arm_length=0.21,
        inertia=(0.01, 0.01, 0.02),
        kF=9.9865e-6,
        kM=9.9865e-6 * 0.016,
        u_max=838.0**2,
        rotor_radius=0.127,
    ),
}


def _presets_of_real_vehicles() -> dict[str, Vehicle]:
    """Published vehicles (docs/vehicles.md, "Presets", cites each source).
    u is the squared rotor speed (rad/s)², kF the thrust coefficient."""
    return {
        # Bitcraze Crazyflie 2.x as rotorpy 3.0 ships it (rotorpy/vehicles/
        # crazyflie_params.py; Förster, "System identification of the
        # Crazyflie 2.0 nano quadrocopter", ETH 2015): 30 g, arm 0.043 m on
        # the diagonals, k_eta 2.3e-8 N/(rad/s)², k_m 7.8e-10 N·m/(rad/s)²,
        # 2500 rad/s at most (thrust to weight 1.95), motor time constant
        # 0.072 s; Bitcraze's 45 mm propellers (radius 0.0225 m). Izz is
        # Ixx + Iyy, the bound of any body's moments: the published 2.89e-5
        # exceeds it by 1 % (a flat vehicle's measured moments sit on it).
        "crazyflie": Vehicle(
            name="crazyflie",
            mass=0.03,
            arm_length=0.043,
            inertia=(1.43e-5, 1.43e-5, 2.86e-5),
            kF=2.3e-8,
            kM=7.8e-10,
            u_max=2500.0**2,
            rotor_radius=0.0225,
            motor_time_constant=0.072,
            layout="x",
        ),
        # AscTec Hummingbird as rotorpy 3.0 ships it (rotorpy/vehicles/
        # hummingbird_params.py): 0.5 kg, arm 0.17 m on the diagonals,
        # rotor radius 0.10 m, k_eta 5.57e-6, k_m 1.36e-7, 1500 rad/s at
        # most (thrust to weight 10.2), motor time constant 5 ms.
        "hummingbird": Vehicle(
            name="hummingbird",
            mass=0.5,
            arm_length=0.17,
            inertia=(3.65e-3, 3.68e-3, 7.03e-3),
            kF=5.57e-6,
            kM=1.36e-7,
            u_max=1500.0**2,
            rotor_radius=0.10,
            motor_time_constant=0.005,
            layout="x",
        ),
        # Holybro X500 as PX4's Gazebo model describes it (PX4/PX4-gazebo-
        # models, models/x500_base/model.sdf and models/x500/model.sdf):
        # 2.0 kg, rotors at (±0.174, ±0.174) m (arm 0.246 m), 13-inch
        # propellers (radius 0.165 m), motor constant 8.54858e-6 N/(rad/s)²,
        # moment constant 0.016 m, 1000 rad/s at most (thrust to weight
        # 1.74), motor time constant 0.0125 s up (0.025 s down).
        "x500": Vehicle(
            name="x500",
            mass=2.0,
            arm_length=0.174 * math.sqrt(2.0),
            inertia=(0.02166666666666667, 0.02166666666666667, 0.04000000000000001),
            kF=8.54858e-6,
            kM=8.54858e-6 * 0.016,
            u_max=1000.0**2,
            rotor_radius=0.165,
            motor_time_constant=0.0125,
            layout="x",
        ),
    }


VEHICLES.update(_presets_of_real_vehicles())


MODELS_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), "models")


def vehicle_model_path(name: str) -> str:
    """The shipped SDFormat model of vehicle `name` (`config.vehicle_model`)."""
    if name not in VEHICLES:
        raise ValueError(f"vehicle = {name!r}: must be one of {sorted(VEHICLES)}")
    return os.path.join(MODELS_DIR, f"{name}.sdf")


def _positive(value) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0
    )


def vehicle_problems(vehicle: Vehicle) -> list[tuple[str, object, str]]:
    """Problems with `vehicle` as (field, value, reason); [] if none."""
    problems = []
    for name in ("mass", "arm_length", "kF", "kM", "u_max", "rotor_radius"):
        if not _positive(getattr(vehicle, name)):
            problems.append((name, getattr(vehicle, name), "must be a number > 0"))
    tau = vehicle.motor_time_constant
    if not (_positive(tau) or tau == 0):
        problems.append(("motor_time_constant", tau, "must be a number ≥ 0"))
    if vehicle.layout not in LAYOUTS:
        problems.append(("layout", vehicle.layout, f"must be one of {LAYOUTS}"))
    inertia = vehicle.inertia
    if len(inertia) != 3 or not all(_positive(i) for i in inertia):
        problems.append(("inertia", list(inertia), "must be 3 numbers > 0 [kg·m²]"))
    elif 2.0 * max(inertia) > sum(inertia) * (1.0 + 1e-12):
        # The principal moments of any body: each at most the sum of the
        # others (Drake's Parser refuses a model that breaks it too).
        problems.append(
            ("inertia", list(inertia), "must satisfy the triangle inequality")
        )
    if not problems and vehicle.thrust_to_weight < MIN_THRUST_TO_WEIGHT:
        problems.append(
            (
                "u_max",
                vehicle.u_max,
                f"thrust to weight 4 kF u_max / (m g) = "
                f"{vehicle.thrust_to_weight:.3g} must be ≥ {MIN_THRUST_TO_WEIGHT}",
            )
        )
    return problems


class VehicleError(ValueError):
    """A vehicle that cannot fly; the message is one line naming the field."""


def as_vehicle(vehicle: "str | Vehicle", where: str = "vehicle") -> Vehicle:
    """The `Vehicle` of what a user gives as `vehicle`: a preset's name, or a
    Vehicle (checked). A `VehicleModel` is read by
    `config.vehicle_model.read_vehicle_model` first. Raises VehicleError
    naming `where`'s field and value."""
    if isinstance(vehicle, str):
        if vehicle not in VEHICLES:
            raise VehicleError(
                f"{where} = {vehicle!r}: must be one of {sorted(VEHICLES)} "
                "or a !Vehicle / !VehicleModel"
            )
        return VEHICLES[vehicle]
    if not isinstance(vehicle, Vehicle):
        raise VehicleError(
            f"{where} = {vehicle!r}: must be a preset's name or a Vehicle"
        )
    vehicle = replace(vehicle)  # inertia a tuple
    for name, value, reason in vehicle_problems(vehicle):
        raise VehicleError(f"{where}.{name} = {value!r}: {reason}")
    return vehicle
