"""The shipped SDFormat model of each vehicle, written from its `Vehicle`
record (the one source of truth): one free body "body" at the centre of
mass with the record's mass and principal inertia; visuals of a hub box,
four arms and four rotor discs, drawn only (no perception role: a camera
on the vehicle does not see them, as with `systems.sensors.VehicleGeometry`);
and one collision sphere of the `collision_radius` that the navigator
grows obstacles by.

Rotors follow Drake's QuadrotorPlant: rotor k sits at arm_length along the
body's +x, +y, −x, −y axes (k = 0..3), pushes along +z, and rotors 0 and 2
twist +z while 1 and 3 twist −z (`ROTOR_SPIN`).

`python -m mfi_drake.config.vehicle_model` rewrites the files under
mfi_drake/models/ after a record changes (tests/test_multibody_vehicle.py
checks that they are up to date).
"""

from dataclasses import dataclass

import numpy as np

from mfi_drake.config.vehicles import VEHICLES, Vehicle, vehicle_model_path
from mfi_drake.files import write_text

# Sign of each rotor's reaction moment about +z (QuadrotorPlant's Mz).
ROTOR_SPIN = (1.0, -1.0, 1.0, -1.0)
VEHICLE_RGBA = (0.1, 0.3, 0.8, 1.0)
ROTOR_HEIGHT = 0.03  # m, rotor discs drawn above the arms


@dataclass(frozen=True)
class Part:
    """One visual shape: a "box" (size = x, y, z lengths) or a "cylinder"
    (size = radius, length) at `xyz`, turned by `yaw` about z."""

    name: str
    shape: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float]
    yaw: float = 0.0


def rotor_positions(arm_length: float) -> np.ndarray:
    """Rotor k's centre in the body frame (4 × 3): QuadrotorPlant's moments
    Mx = L(F1 − F3), My = L(F2 − F0) put rotors 0..3 on +x, +y, −x, −y."""
    angles = np.arange(4) * np.pi / 2
    return arm_length * np.column_stack(
        [np.round(np.cos(angles)), np.round(np.sin(angles)), np.zeros(4)]
    )


def vehicle_parts(arm_length: float, rotor_radius: float) -> list[Part]:
    """The drawn vehicle: a flat hub, four arms to the rotor axes and four
    rotor discs."""
    parts = [Part("hub", "box", (0.6 * arm_length, 0.6 * arm_length, 0.05), (0, 0, 0))]
    for k, rotor in enumerate(rotor_positions(arm_length)):
        x, y = float(rotor[0]), float(rotor[1])
        parts.append(
            Part(
                f"arm_{k}",
                "box",
                (arm_length, 0.02, 0.02),
                (x / 2, y / 2, 0.0),
                k * np.pi / 2,
            )
        )
        parts.append(
            Part(f"rotor_{k}", "cylinder", (rotor_radius, 0.01), (x, y, ROTOR_HEIGHT))
        )
    return parts


def _numbers(values) -> str:
    # + 0.0 writes −0.0 as 0.0.
    return " ".join(repr(float(v) + 0.0) for v in values)


def _geometry(part: Part) -> str:
    if part.shape == "box":
        return f"<box><size>{_numbers(part.size)}</size></box>"
    radius, length = part.size
    return (
        f"<cylinder><radius>{radius!r}</radius><length>{length!r}</length></cylinder>"
    )


def vehicle_sdf(vehicle: Vehicle) -> str:
    """The SDFormat text of `vehicle`'s model (see the module's docstring)."""
    ixx, iyy, izz = vehicle.inertia
    visuals = "".join(
        f"""
      <visual name="{part.name}">
        <pose>{_numbers(part.xyz)} 0.0 0.0 {float(part.yaw)!r}</pose>
        <geometry>{_geometry(part)}</geometry>
        <material><diffuse>{_numbers(VEHICLE_RGBA)}</diffuse></material>
        <drake:perception_properties enabled="false"/>
      </visual>"""
        for part in vehicle_parts(vehicle.arm_length, vehicle.rotor_radius)
    )
    return f"""<?xml version="1.0"?>
<!-- Written by mfi_drake.config.vehicle_model from the record "{vehicle.name}"
     of mfi_drake/config/vehicles.py; edit the record, not this file. -->
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="{vehicle.name}">
    <link name="body">
      <inertial>
        <mass>{vehicle.mass!r}</mass>
        <inertia>
          <ixx>{ixx!r}</ixx><ixy>0.0</ixy><ixz>0.0</ixz>
          <iyy>{iyy!r}</iyy><iyz>0.0</iyz><izz>{izz!r}</izz>
        </inertia>
      </inertial>{visuals}
      <collision name="collision_sphere">
        <geometry><sphere><radius>{vehicle.collision_radius!r}</radius></sphere></geometry>
      </collision>
    </link>
  </model>
</sdf>
"""


def write_vehicle_models() -> None:
    """Rewrites every shipped vehicle's model file."""
    for name, vehicle in VEHICLES.items():
        write_text(vehicle_model_path(name), vehicle_sdf(vehicle))


if __name__ == "__main__":
    write_vehicle_models()
