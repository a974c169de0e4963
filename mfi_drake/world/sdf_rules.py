"""What Drake needs of SDFormat and URDF, for `sdformat`'s rewrite: the
children and attributes kept of each element, what either format defines
that a flight does not read (counted, not warned about), the placeholder
marks, and the readers of numbers and poses (errors one line naming the
file and line)."""

import math
import re
import xml.etree.ElementTree as ET

from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

MARK = re.compile(r"__mfi_(mesh|plane|heightmap|polyline)_(\d+)__(.*)$")
FRAMED = ("link", "model", "frame")  # what a model's frame names must not repeat
CONVEX = "drake:declare_convex"  # Drake's: a mesh flown as its hull
# What Drake needs of SDFormat and URDF: the children and attributes kept.
SDF = {
    "sdf": ({"world", "model"}, {"version"}),
    "world": ({"model", "include", "frame"}, {"name"}),
    "model": (
        {"static", "pose", "link", "model", "include", "frame", "joint"},
        {"name"},
    ),
    # Kept as the frame it defines; its type and parent are not read.
    "joint": ({"pose", "child"}, {"name", "type"}),
    "link": ({"pose", "collision"}, {"name"}),
    "collision": ({"pose", "geometry"}, {"name"}),
    "frame": ({"pose"}, {"name", "attached_to"}),
    "geometry": (
        {"box", "sphere", "cylinder", "capsule", "ellipsoid", "mesh", "plane"}
        | {"heightmap", "polyline"},
        set(),
    ),
    "heightmap": ({"uri", "size", "pos"}, set()),  # `world.terrain`'s
    "polyline": ({"point", "height"}, set()),  # `world.extrusions`'
    "box": ({"size"}, set()),
    "sphere": ({"radius"}, set()),
    "cylinder": ({"radius", "length"}, set()),
    "capsule": ({"radius", "length"}, set()),
    "ellipsoid": ({"radii"}, set()),
    "mesh": ({"uri", "scale", CONVEX}, set()),
    "plane": ({"normal", "size"}, set()),
    "pose": (set(), {"relative_to", "degrees", "rotation_format"}),
}
URDF = {
    "robot": ({"link", "joint"}, {"name"}),
    "link": ({"collision"}, {"name"}),
    "collision": ({"origin", "geometry"}, {"name"}),
    "geometry": ({"box", "sphere", "cylinder", "capsule", "mesh", "plane"}, set()),
    "box": (set(), {"size"}),
    "plane": (set(), {"normal"}),  # PyBullet's
    "sphere": (set(), {"radius"}),
    "cylinder": (set(), {"radius", "length"}),
    "capsule": (set(), {"radius", "length"}),
    "mesh": ({CONVEX}, {"filename", "scale"}),
    "origin": (set(), {"xyz", "rpy"}),
    "joint": ({"origin", "parent", "child"}, {"name", "type"}),
    "parent": (set(), {"link"}),
    "child": (set(), {"link"}),
}
# Elements either format defines that a flight does not read: counted in
# the one line that says what was read past, not warned about.
_KNOWN = (
    "visual sensor plugin light actor gui scene physics audio_source audio_sink "
    "inertial joint gripper self_collide allow_auto_disable enable_wind kinematic "
    "gravity velocity_decay surface laser_retro max_contacts spherical_coordinates "
    "magnetic_field atmosphere wind road population battery projector "
    "particle_emitter must_be_base_link heightmap polyline image submesh state "
    "gazebo transmission material limit axis axis2 dynamics safety_controller "
    "calibration mimic contact uri name static placement_frame parent texture "
    "blend use_terrain_paging sampling point "
    "thread_pitch gearbox_ratio gearbox_reference_body"
)
KNOWN = frozenset(_KNOWN.split())


def pose_matrix(element: ET.Element | None, where: str) -> RigidTransform:
    """An SDFormat <pose> (x y z roll pitch yaw, radians unless
    degrees="true", or x y z qx qy qz qw) as a transform."""
    if element is None:
        return RigidTransform()
    values = numbers((element.text or "0 0 0 0 0 0"), where, "pose")
    if len(values) == 7 and element.get("rotation_format") == "quat_xyzw":
        x, y, z, w = values[3:]
        norm = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
        rotation = RotationMatrix(Quaternion(w / norm, x / norm, y / norm, z / norm))
        return RigidTransform(rotation, values[:3])
    if len(values) != 6:
        raise ValueError(f"{where}: a pose must hold 6 numbers, not {element.text!r}")
    angles = values[3:]
    if element.get("degrees") == "true":
        angles = [math.radians(a) for a in angles]
    return RigidTransform(RollPitchYaw(angles), values[:3])


def numbers(text: str, where: str, what: str) -> list[float]:
    try:
        values = [float(x) for x in text.split()]
    except ValueError:
        values = [math.nan]
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{where}: {what} must hold finite numbers, not {text!r}")
    return values


def pose_text(X: RigidTransform) -> str:
    values = [*X.translation(), *RollPitchYaw(X.rotation()).vector()]
    return " ".join(repr(float(v)) for v in values)
