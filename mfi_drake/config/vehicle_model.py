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

`read_vehicle_model` goes the other way: a user's URDF or SDFormat file
(`vehicle: !VehicleModel {file: ...}`) read by Drake's Parser into a
`Vehicle` (docs/vehicles.md, "A model file").

`python -m mfi_drake.config.vehicle_model` rewrites the files under
mfi_drake/models/ after a record changes (tests/test_multibody_vehicle.py
checks that they are up to date).
"""

import math
import os
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Box, Capsule, Cylinder, Ellipsoid, Role, SceneGraph, Sphere
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.config.vehicles import (
    VEHICLES,
    Vehicle,
    VehicleError,
    as_vehicle,
    vehicle_model_path,
    vehicle_problems,
)
from mfi_drake.files import write_text
from mfi_drake.maths.quadcopter import rotor_angles, rotor_xy

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


def rotor_positions(arm_length: float, layout: str = "+") -> np.ndarray:
    """Rotor k's centre in the body frame (4 × 3): QuadrotorPlant's moments
    Mx = L(F1 − F3), My = L(F2 − F0) put rotors 0..3 on +x, +y, −x, −y
    ("+"); an "x" vehicle's sit 45° further (`quadcopter.rotor_xy`)."""
    return np.column_stack([rotor_xy(arm_length, layout), np.zeros(4)])


def vehicle_parts(
    arm_length: float, rotor_radius: float, layout: str = "+"
) -> list[Part]:
    """The drawn vehicle: a flat hub, four arms to the rotor axes and four
    rotor discs."""
    parts = [Part("hub", "box", (0.6 * arm_length, 0.6 * arm_length, 0.05), (0, 0, 0))]
    angles = rotor_angles(layout)
    for k, rotor in enumerate(rotor_positions(arm_length, layout)):
        x, y = float(rotor[0]), float(rotor[1])
        parts.append(
            Part(
                f"arm_{k}",
                "box",
                (arm_length, 0.02, 0.02),
                (x / 2, y / 2, 0.0),
                float(angles[k]),
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
        for part in vehicle_parts(
            vehicle.arm_length, vehicle.rotor_radius, vehicle.layout
        )
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


@dataclass
class VehicleModel:
    """A vehicle whose mass, inertia and arm length Drake's Parser reads from
    a URDF or SDFormat `file` (relative to the scenario's YAML file), and
    whose rotor constants are given (YAML `!VehicleModel {...}`)."""

    file: str = ""
    kF: float = 0.0  # N per unit of u
    kM: float = 0.0  # N·m per unit of u
    u_max: float = 0.0  # largest rotor command
    rotor_radius: float = 0.0  # m
    motor_time_constant: float = 0.0  # s (see `Vehicle`)
    # "+" or "x"; "" : from the rotor bodies' places ("+" without them).
    layout: str = ""
    name: str = ""  # "": the file's first model's name


def vehicle_field_problems(vehicle) -> list[tuple[str, object, str]]:
    """A scenario's `vehicle` field's problems as (field, value, reason): an
    unknown preset, a `Vehicle`'s bad values (`vehicle_problems`); a
    `VehicleModel`'s are found where its file is read, at loading."""
    if isinstance(vehicle, VehicleModel):
        return []
    if isinstance(vehicle, Vehicle):
        return [(f"vehicle.{n}", v, why) for n, v, why in vehicle_problems(vehicle)]
    if vehicle not in VEHICLES:
        shown = f"must be one of {sorted(VEHICLES)} or a !Vehicle / !VehicleModel"
        return [("vehicle", vehicle, shown)]
    return []


ROTOR_NAMES = ("rotor", "prop")  # a body whose name holds one is a rotor


def read_vehicle_model(model: VehicleModel, base_dir: str = "") -> Vehicle:
    """The `Vehicle` of `model` (checked by `as_vehicle`): mass and principal
    inertia of all the file's bodies welded at their default configuration,
    about their centre of mass, in the frame of the one floating body; arm
    length the mean horizontal distance from that centre to the rotor
    bodies (four bodies whose name holds "rotor" or "prop"), whose places
    also tell the layout. A file without rotor bodies: the arm length is
    the horizontal extent of the floating body's collision geometry about
    the centre, less `rotor_radius` (a collision sphere of the shipped
    models gives back their arm length). Raises VehicleError, one line."""
    path = os.path.join(base_dir, model.file)
    where = f"vehicle.file = {model.file!r}"
    if not model.file.endswith((".urdf", ".sdf")):
        raise VehicleError(f"{where}: must be a .urdf or .sdf file")
    if not os.path.isfile(path):
        raise VehicleError(f"{where}: no such file")
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    try:
        instances = Parser(plant).AddModels(path)
        plant.Finalize()
    except RuntimeError as e:
        raise VehicleError(f"{where}: {' '.join(str(e).split())}") from None
    bases = list(plant.GetFloatingBaseBodies())
    if len(bases) != 1:
        raise VehicleError(f"{where}: must hold one free body, not {len(bases)}")
    base = plant.get_body(bases[0])
    context = plant.CreateDefaultContext()
    bodies = [i for i in plant.GetBodyIndices(instances[0]) if i != 0]
    M = plant.CalcSpatialInertia(context, base.body_frame(), bodies)
    com = M.get_com()
    inertia = M.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
    rotors = [
        plant.EvalBodyPoseInWorld(context, plant.get_body(i)).translation()
        - plant.EvalBodyPoseInWorld(context, base).translation()
        for i in bodies
        if i != base.index()
        and any(n in plant.get_body(i).name().lower() for n in ROTOR_NAMES)
    ]
    if rotors and len(rotors) != 4:
        raise VehicleError(f"{where}: has {len(rotors)} rotor bodies, not 4")
    layout = model.layout or "+"
    if rotors:
        xy = np.array(rotors)[:, :2] - com[:2]
        arm = float(np.mean(np.hypot(xy[:, 0], xy[:, 1])))
        layout = model.layout or _layout(xy, where)
    else:
        arm = _extent(plant, scene_graph, base, com, where) - model.rotor_radius
    return as_vehicle(
        Vehicle(
            name=model.name or plant.GetModelInstanceName(instances[0]),
            mass=M.get_mass(),
            arm_length=arm,
            inertia=[float(inertia[i, i]) for i in range(3)],
            kF=model.kF,
            kM=model.kM,
            u_max=model.u_max,
            rotor_radius=model.rotor_radius,
            motor_time_constant=model.motor_time_constant,
            layout=layout,
        ),
        "vehicle",
    )


def _layout(xy: np.ndarray, where: str) -> str:
    """ "+" where every rotor lies on a body axis, "x" where on a diagonal."""
    angles = np.degrees(np.arctan2(xy[:, 1], xy[:, 0])) % 90.0
    if np.all(np.minimum(angles, 90.0 - angles) < 5.0):
        return "+"
    if np.all(np.abs(angles - 45.0) < 5.0):
        return "x"
    raise VehicleError(f"{where}: its rotors lie neither on the axes nor diagonals")


def _extent(plant, scene_graph: SceneGraph, base, com, where: str) -> float:
    """The largest horizontal distance from `com` of the collision geometry
    on `base`: a box's corners exactly, a round shape through its centre
    plus its largest radius."""
    inspector = scene_graph.model_inspector()
    frame = plant.GetBodyFrameIdOrThrow(base.index())
    reach = 0.0
    for geometry in inspector.GetGeometries(frame, Role.kProximity):
        shape = inspector.GetShape(geometry)
        X = inspector.GetPoseInFrame(geometry)
        if isinstance(shape, Box):
            half = 0.5 * np.array([shape.width(), shape.depth(), shape.height()])
            signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1)
            points = X.multiply(signs * half[:, None])[:2] - com[:2, None]
            reach = max(reach, float(np.max(np.hypot(*points))))
            continue
        if isinstance(shape, Sphere):
            radius = shape.radius()
        elif isinstance(shape, Cylinder | Capsule):
            radius = math.hypot(shape.radius(), 0.5 * shape.length())
            radius += shape.radius() if isinstance(shape, Capsule) else 0.0
        elif isinstance(shape, Ellipsoid):
            radius = max(shape.a(), shape.b(), shape.c())
        else:
            raise VehicleError(
                f"{where}: a {type(shape).__name__} collision shape has no "
                "extent here; give the file rotor bodies"
            )
        reach = max(reach, float(np.hypot(*(X.translation()[:2] - com[:2]))) + radius)
    if reach == 0.0:
        raise VehicleError(f"{where}: has neither rotor bodies nor collision shapes")
    return reach


def write_vehicle_models() -> None:
    """Rewrites every shipped vehicle's model file."""
    for name, vehicle in VEHICLES.items():
        write_text(vehicle_model_path(name), vehicle_sdf(vehicle))


if __name__ == "__main__":
    write_vehicle_models()
