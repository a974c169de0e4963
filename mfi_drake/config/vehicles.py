"""Vehicle presets mapped onto Drake's QuadrotorPlant(m, L, I, kF, kM).

Drake's plant takes four inputs u_i ≥ 0; rotor i pushes kF·u_i and twists
kM·u_i. For `drake_default` u_i is a force in newtons (kF = 1). For `pelican`
u_i is the squared rotor speed ω_i² [(rad/s)²], so kF is RotorS' motor
constant and kM = kF · moment constant.
"""

import os
from dataclasses import dataclass

import numpy as np

from mfi_drake.maths.constants import GRAVITY


@dataclass(frozen=True)
class Vehicle:
    name: str
    mass: float  # kg
    arm_length: float  # m, centre to rotor axis (the plant's L)
    inertia: tuple[float, float, float]  # kg·m², principal Ixx, Iyy, Izz
    kF: float  # N per unit of u
    kM: float  # N·m per unit of u
    u_max: float  # largest rotor command (the saturation of the mixer)
    rotor_radius: float  # m

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


MODELS_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), "models")


def vehicle_model_path(name: str) -> str:
    """The shipped SDFormat model of vehicle `name` (`config.vehicle_model`)."""
    if name not in VEHICLES:
        raise ValueError(f"vehicle = {name!r}: must be one of {sorted(VEHICLES)}")
    return os.path.join(MODELS_DIR, f"{name}.sdf")
