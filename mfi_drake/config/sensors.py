"""The sensors a scenario flies (`sensor:`): the paper's sphere sensor
and on-board depth cameras (one, or a rig), with their checks."""

import math
from dataclasses import dataclass, field

from pydrake.common.schema import Transform

from mfi_drake.config.checks import check_positive, check_vector, fail
from mfi_drake.maths.layout import OBSTACLE_COUNT


@dataclass
class SphereSensor:
    """Sees every obstacle point within `radius` of the vehicle centre."""

    radius: float = 3.0  # m, the paper's r_s
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


@dataclass
class CameraImage:
    """The depth image of an on-board camera (square pixels, principal point
    at the centre)."""

    width: int = 160  # pixels
    height: int = 120  # pixels
    fov_y_deg: float = 60.0  # vertical field of view, degrees
    max_range: float = 6.0  # m; farther pixels are "no return"


MEMORY_S = 6.0  # s, default T: max_range / v_d (docs/depth_camera.md, "Memory")


@dataclass
class Gimbal:
    """A pan–tilt gimbal, stabilised in the world, that turns the camera
    toward the estimated velocity (docs/depth_camera.md, "Gimbal")."""

    rate_deg_s: float = 180.0  # largest slew rate of each axis
    min_speed: float = 0.2  # m/s; slower, the gimbal holds its direction


@dataclass
class DepthCamera(CameraImage):
    """An on-board depth camera (paper §VI-B) looking +x: a rig of one
    camera, fixed to the body or on a gimbal."""

    rate_hz: float = 30.0  # frames per second
    # The camera's pose: optical centre in the body frame [m] and orientation
    # [deg] in the body frame, or on a gimbal in the gimbal's frame (zero:
    # looking along its +x, image up = its +z).
    position: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    rpy_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    memory_s: float = MEMORY_S  # s, T: how long a seen point is remembered
    # None: fixed to the body, as in the paper; a `Gimbal`: looking where the
    # vehicle goes (docs/depth_camera.md, "Gimbal").
    gimbal: Gimbal | None = None
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


def looking_forward() -> Transform:
    """X_BC of a camera at the body origin looking along body +x, image up =
    body +z (C: Drake's camera frame, +z along the view, +x image right)."""
    X_BC = Transform()
    X_BC.set_rotation_rpy_deg([-90.0, 0.0, -90.0])
    return X_BC


@dataclass
class RigCamera(CameraImage):
    """A camera of a `DepthCameraRig`, posed as Drake poses a camera:
    X_BC: {translation: [x, y, z], rotation: !Rpy {deg: [r, p, y]}}, the
    camera frame C (+z along the view, +x image right, +y image down) in the
    body frame B. Default: `looking_forward`."""

    X_BC: Transform = field(default_factory=looking_forward)


@dataclass
class DepthCameraRig:
    """Depth cameras on the body, rendering together at rate_hz; what they
    see is fused into one memory and one reading."""

    cameras: list[RigCamera] = field(default_factory=lambda: [RigCamera()])
    rate_hz: float = 30.0  # frames per second, every camera
    memory_s: float = MEMORY_S  # s, T: how long a seen point is remembered
    readings: int = OBSTACLE_COUNT  # obstacles reported, nearest first (≥ 1)


Sensor = SphereSensor | DepthCamera | DepthCameraRig
Cameras = DepthCamera | DepthCameraRig  # the sensors that render depth images


MIN_DEPTH = 0.02  # m; a depth camera's closer pixels come back as "too close"


def _check_image(where: str, name: str, camera: CameraImage) -> None:
    """`name`: the camera's path in the scenario, e.g. "sensor.cameras[1]"."""
    for size in ("width", "height"):
        value = getattr(camera, size)
        if not isinstance(value, int) or value <= 0:
            fail(where, f"{name}.{size}", value, "must be a whole number > 0")
    fov = camera.fov_y_deg
    check_positive(where, f"{name}.fov_y_deg", fov)
    if fov >= 180.0:
        fail(where, f"{name}.fov_y_deg", fov, "must be < 180")
    check_positive(where, f"{name}.max_range", camera.max_range)
    if camera.max_range <= MIN_DEPTH:
        fail(where, f"{name}.max_range", camera.max_range, f"must be > {MIN_DEPTH}")


def _check_camera_pose(where: str, name: str, X_BC: Transform) -> None:
    if X_BC.base_frame is not None:
        fail(where, f"{name}.base_frame", X_BC.base_frame, "must be left out (body)")
    if not X_BC.IsDeterministic():
        fail(where, name, X_BC, "must be one fixed pose")
    pose = X_BC.GetDeterministicValue()
    if not all(math.isfinite(x) for x in pose.GetAsMatrix4().ravel()):
        fail(where, name, X_BC, "must hold finite numbers")


def _check_cameras(where: str, sensor: Cameras) -> None:
    check_positive(where, "sensor.rate_hz", sensor.rate_hz)
    check_positive(where, "sensor.memory_s", sensor.memory_s)
    if isinstance(sensor, DepthCamera):
        _check_image(where, "sensor", sensor)
        check_vector(where, "sensor.position", sensor.position)
        check_vector(where, "sensor.rpy_deg", sensor.rpy_deg)
        if sensor.gimbal is not None:
            check_positive(where, "sensor.gimbal.rate_deg_s", sensor.gimbal.rate_deg_s)
            check_positive(where, "sensor.gimbal.min_speed", sensor.gimbal.min_speed)
        return
    if not sensor.cameras:
        fail(where, "sensor.cameras", sensor.cameras, "must hold a camera")
    for i, camera in enumerate(sensor.cameras):
        _check_image(where, f"sensor.cameras[{i}]", camera)
        _check_camera_pose(where, f"sensor.cameras[{i}].X_BC", camera.X_BC)


def check_sensor(where: str, sensor: Sensor) -> None:
    """Raises ScenarioError for the first problem of `sensor` (`sensor:`)."""
    if isinstance(sensor, SphereSensor):
        check_positive(where, "sensor.radius", sensor.radius)
    elif isinstance(sensor, Cameras):
        _check_cameras(where, sensor)
    else:
        fail(where, "sensor", sensor, "unknown sensor")
    readings = sensor.readings
    if isinstance(readings, bool) or not isinstance(readings, int) or readings < 1:
        fail(where, "sensor.readings", readings, "must be an integer >= 1")
