"""The on-board depth cameras (paper §VI-B) and the perception that turns
their images into the navigator's "obstacle" reading.

For camera i of the scenario's rig (`DepthCamera` is a rig of one):

    SceneGraph ──query──▶ RgbdSensor "rgbd_sensor_i" ──depth──▶ DepthImageToPointCloud
                              │ depth_image_i                      "point_cloud_i"
                              ▼                                        │ point_cloud_i
    state estimate ──▶ DepthCameraSensor "sensor" ◀────────────────────┘
                              │ obstacle
                              ▼ navigator

The RgbdSensor renders with VTK (headless, EGL) from the body frame's true
pose; the obstacles carry the perception role, the vehicle's own shapes do
not. Drake's DepthImageToPointCloud back-projects the image in the camera
frame. `DepthCameraSensor` places that cloud in the world with the
controller's state estimate, as an on-board computer would, and keeps the
percept of `maths.perception` (the memory and the voxels of the nearest
obstacles) in abstract state, updated at the rig's rate; between frames each
reading is re-read from its obstacle's voxel as the estimated position moves.
A `DepthCamera` with a gimbal rides on the frame of `gimbal.GimbalPose`
instead of the body's, and `DepthCameraSensor` points it along the
estimated velocity.
"""

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    DepthRange,
    DepthRenderCamera,
    FrameId,
    MakeRenderEngineVtk,
    RenderCameraCore,
    RenderEngineVtkParams,
    SceneGraph,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.perception import DepthImageToPointCloud, PointCloud
from pydrake.systems.framework import DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, RgbdSensor

from mfi_drake.config.sensors import (
    MIN_DEPTH,
    CameraImage,
    Cameras,
    DepthCamera,
    Gimbal,
)
from mfi_drake.maths.gimbal import gimbal_rotation, point_gimbal
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    STATE_SIZE,
    VELOCITY,
    obstacle_signal,
    signal_size,
)
from mfi_drake.maths.perception import (
    Intrinsics,
    Percept,
    Thinning,
    View,
    perceive,
)
from mfi_drake.systems.gimbal import GimbalPose

RENDERER = "vtk"
NEAR_CLIP = 0.01  # m, the renderer's near clipping plane

# Drake's camera frame C looks along +z with +x to the image's right and +y
# down. `DepthCamera` gives the camera's orientation for a "look" frame L
# that, like the body, has +x forward and +z up; R_LC maps one to the other.
R_LC = RotationMatrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))


@dataclass(frozen=True)
class MountedCamera:
    """A camera's image and its pose X_MC on its mount M: the body, or the
    gimbal's frame."""

    image: CameraImage
    X_MC: RigidTransform


def mounted_cameras(sensor: Cameras) -> list[MountedCamera]:
    """The rig's cameras. A `DepthCamera` is one, posed by position and
    rpy_deg (zero rpy: looking along the mount's +x, image up = its +z); on a
    gimbal, `position` is the gimbal's on the body and the camera sits at
    the gimbal's centre."""
    if isinstance(sensor, DepthCamera):
        R_ML = RollPitchYaw(np.radians(sensor.rpy_deg)).ToRotationMatrix()
        p_MC = np.zeros(3) if sensor.gimbal else np.asarray(sensor.position, float)
        return [MountedCamera(sensor, RigidTransform(R_ML @ R_LC, p_MC))]
    return [MountedCamera(c, c.X_BC.GetDeterministicValue()) for c in sensor.cameras]


def gimbal_of(sensor: Cameras) -> Gimbal | None:
    """The gimbal carrying the sensor's camera (none: fixed to the body)."""
    return sensor.gimbal if isinstance(sensor, DepthCamera) else None


def camera_info(camera: CameraImage) -> CameraInfo:
    """Square pixels, principal point at the image centre."""
    return CameraInfo(camera.width, camera.height, np.radians(camera.fov_y_deg))


def unit_rays(info: CameraInfo) -> np.ndarray:
    """(3, height·width) the pixels' rays with z = 1, row-major: Drake's
    DepthImageToPointCloud of an image at depth 1 (so the projection model
    is Drake's own)."""
    converter = DepthImageToPointCloud(info)
    context = converter.CreateDefaultContext()
    image = ImageDepth32F(info.width(), info.height(), 1.0)
    converter.depth_image_input_port().FixValue(context, image)
    return converter.point_cloud_output_port().Eval(context).xyzs().astype(float)


class CameraModel:
    """What the perception keeps of a mounted camera (a copy)."""

    def __init__(self, camera: MountedCamera):
        info = camera_info(camera.image)
        self.intrinsics = Intrinsics(
            info.width(),
            info.height(),
            info.focal_x(),
            info.focal_y(),
            info.center_x(),
            info.center_y(),
        )
        self.X_MC = RigidTransform(camera.X_MC)
        self._R_MC = self.X_MC.rotation().matrix()
        self._p_MC = self.X_MC.translation()
        self.max_range = float(camera.image.max_range)
        # Thinned toward the mount's origin: the vehicle centre, or the
        # gimbal's centre (the same point unless the gimbal is set off it).
        centre = self.X_MC.inverse().translation()
        self.thinning = Thinning(unit_rays(info), info.width(), info.height(), centre)

    def view(
        self, R_WM: np.ndarray, p_WM: np.ndarray, cloud: PointCloud, depth
    ) -> View:
        """The frame of this camera's `cloud` (camera frame) and `depth`
        image (ImageDepth32F), thinned and placed with the mount's pose
        (R_WM, p_WM)."""
        z = depth.data[:, :, 0]
        return View(
            self.thinning(cloud.xyzs(), z),
            R_WM @ self._R_MC,
            p_WM + R_WM @ self._p_MC,
            self.intrinsics,
            z,
            self.max_range,
        )


class DepthCameraSensor(LeafSystem):
    """The rig's depth images → the k nearest obstacles' closest points.

    .. pydrake_system::

        name: DepthCameraSensor
        input_ports:
        - depth_image_0
        - point_cloud_0
        - ...
        - state
        output_ports:
        - obstacle
        - frames_rendered
        - gimbal_angles (with a gimbal)

    Per camera i: "depth_image_i", an ImageDepth32F, and "point_cloud_i",
    its DepthImageToPointCloud cloud in the camera frame. "state": the
    controller's state estimate (12), which places the clouds in the world
    and the vehicle in the memory. "obstacle": `readings` readings
    [r_o, seen], nearest first (`maths.layout`); "frames_rendered": images
    rendered so far. Abstract state: the `Percept`, updated every 1/rate_hz
    s from t = 0 (`perceive`), all cameras at once; discrete state: the image
    count. `cameras` holds a `CameraModel` (a copy) per camera.

    With a `gimbal` (at p_BG on the body), the cameras' mount is the
    gimbal's frame, and this system points it: "gimbal_angles" (pan, tilt)
    [rad], from (0, 0), looking along world +x; each frame, after the images
    are placed, it turns them toward the estimated velocity
    (`maths.gimbal.point_gimbal`), at most `gimbal.rate_deg_s` / rate_hz a
    frame. Without one the mount is the body.
    """

    def __init__(
        self,
        cameras: list[MountedCamera],
        rate_hz: float,
        memory_s: float,
        gimbal: Gimbal | None = None,
        p_BG=(0.0, 0.0, 0.0),
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self.cameras = [CameraModel(camera) for camera in cameras]
        self._count = int(readings)
        self._memory_s = float(memory_s)
        self._gimbal = gimbal
        self._p_BG = np.asarray(p_BG, dtype=float)
        if gimbal is not None:
            self._max_step = np.radians(gimbal.rate_deg_s) / rate_hz
            self._angles = self.DeclareDiscreteState(2)
            self.DeclareStateOutputPort("gimbal_angles", self._angles)
        # Remembered points farther than any camera sees are forgotten.
        self._reach = max(c.max_range for c in self.cameras)
        self._images = [
            self.DeclareAbstractInputPort(
                f"depth_image_{i}", AbstractValue.Make(ImageDepth32F())
            )
            for i in range(len(cameras))
        ]
        self._clouds = [
            self.DeclareAbstractInputPort(
                f"point_cloud_{i}", AbstractValue.Make(PointCloud())
            )
            for i in range(len(cameras))
        ]
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._percept = self.DeclareAbstractState(AbstractValue.Make(Percept.empty()))
        self._frames = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("frames_rendered", self._frames)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate_hz, 0.0, self._frame)
        self.DeclareVectorOutputPort(
            "obstacle",
            signal_size(self._count),
            self._calc,
            prerequisites_of_calc={
                self.abstract_state_ticket(self._percept),
                self._state.ticket(),
            },
        )

    def percept(self, context) -> Percept:
        """The percept held in this system's `context`."""
        return context.get_abstract_state(self._percept).get_value()

    @property
    def gimbal(self) -> Gimbal | None:
        return self._gimbal

    def gimbal_angles(self, context) -> np.ndarray:
        """The gimbal's (pan, tilt) [rad] in this system's `context`."""
        return context.get_discrete_state(self._angles).get_value().copy()

    def set_gimbal_angles(self, context, angles) -> None:
        context.SetDiscreteState(self._angles, np.asarray(angles, dtype=float))

    def next_gimbal_angles(self, angles: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Where the gimbal at `angles` points next, the estimate being x."""
        return point_gimbal(angles, x[VELOCITY], self._max_step, self._gimbal.min_speed)

    def mount_pose(self, x: np.ndarray, angles=None) -> tuple[np.ndarray, np.ndarray]:
        """(R_WM, p_WM) of the cameras' mount, placed with the state estimate
        x: the body, or the gimbal at `angles`."""
        R_WB = RollPitchYaw(x[3], x[4], x[5]).ToRotationMatrix().matrix()
        if self._gimbal is None:
            return R_WB, x[POSITION]
        return gimbal_rotation(*angles), x[POSITION] + R_WB @ self._p_BG

    def _frame(self, context, state):
        """Renders every camera now, updates the percept and points the
        gimbal for the next frame."""
        x = self._state.Eval(context)
        angles = None
        if self._gimbal is not None:
            angles = self.gimbal_angles(context)
            state.get_mutable_discrete_state(self._angles).SetFromVector(
                self.next_gimbal_angles(angles, x)
            )
        R_WM, p_WM = self.mount_pose(x, angles)
        views = [
            camera.view(R_WM, p_WM, cloud.Eval(context), image.Eval(context))
            for camera, image, cloud in zip(
                self.cameras, self._images, self._clouds, strict=True
            )
        ]
        percept = perceive(
            self.percept(context),
            views,
            context.get_time(),
            x[POSITION].copy(),
            self._memory_s,
            self._reach,
            self._count,
        )
        state.get_mutable_abstract_state(self._percept).set_value(percept)
        frames = state.get_mutable_discrete_state(self._frames)
        frames.SetAtIndex(0, frames.GetAtIndex(0) + len(self.cameras))

    def _calc(self, context, output):
        p = self._state.Eval(context)[POSITION]
        nearest = self.percept(context).basins.nearest(p)
        output.SetFromVector(obstacle_signal(nearest, self._count))


def add_depth_cameras(
    builder: DiagramBuilder,
    sensor: Cameras,
    scene_graph: SceneGraph,
    body_frame: FrameId,
    body_pose: OutputPort,
    clear_of: float = 0.0,
) -> DepthCameraSensor:
    """Adds the VTK renderer and, per camera of the rig, an RgbdSensor on the
    vehicle's body frame `body_frame` (of SceneGraph, posed by the
    FramePoseVector port `body_pose`: a `VehicleGeometry`'s or a
    MultibodyPlant's) and a DepthImageToPointCloud, all feeding the
    DepthCameraSensor "sensor"; returns the latter. Its "state" input is
    left for the caller to connect to the controller's state estimate. With
    a gimbal the RgbdSensors ride on the frame of a `GimbalPose` "gimbal"
    that the sensor points. `clear_of`: among several vehicles, their
    collision radius; each camera's near plane is put beyond it, as a real
    depth camera's minimum range (0.2–0.3 m) would."""
    if not scene_graph.HasRenderer(RENDERER):
        scene_graph.AddRenderer(RENDERER, MakeRenderEngineVtk(RenderEngineVtkParams()))
    cameras = mounted_cameras(sensor)
    gimbal = gimbal_of(sensor)
    p_BG = sensor.position if gimbal else (0.0, 0.0, 0.0)
    perception = builder.AddNamedSystem(
        "sensor",
        DepthCameraSensor(
            cameras, sensor.rate_hz, sensor.memory_s, gimbal, p_BG, sensor.readings
        ),
    )
    mount = body_frame
    if gimbal is not None:
        pose = builder.AddNamedSystem(
            "gimbal", GimbalPose(scene_graph, body_frame, p_BG, "gimbal")
        )
        builder.Connect(body_pose, pose.GetInputPort("body_pose"))
        builder.Connect(
            perception.GetOutputPort("gimbal_angles"),
            pose.GetInputPort("gimbal_angles"),
        )
        builder.Connect(
            pose.GetOutputPort("geometry_pose"),
            scene_graph.get_source_pose_port(pose.source_id),
        )
        mount = pose.frame_id
    for i, camera in enumerate(cameras):
        info = camera_info(camera.image)
        near = NEAR_CLIP
        if clear_of > 0.0:  # beyond the own sphere, seen from the lens
            offset = np.linalg.norm(camera.X_MC.translation()) + np.linalg.norm(p_BG)
            near = max(NEAR_CLIP, clear_of + offset + NEAR_CLIP)
        core = RenderCameraCore(
            RENDERER,
            info,
            ClippingRange(near, 1.5 * camera.image.max_range),
            RigidTransform(),
        )
        depth_range = DepthRange(max(MIN_DEPTH, near), camera.image.max_range)
        rgbd = builder.AddNamedSystem(
            f"rgbd_sensor_{i}",
            RgbdSensor(mount, camera.X_MC, DepthRenderCamera(core, depth_range)),
        )
        builder.Connect(
            scene_graph.get_query_output_port(), rgbd.query_object_input_port()
        )
        cloud = builder.AddNamedSystem(f"point_cloud_{i}", DepthImageToPointCloud(info))
        depth = rgbd.depth_image_32F_output_port()
        builder.Connect(depth, cloud.depth_image_input_port())
        builder.Connect(depth, perception.GetInputPort(f"depth_image_{i}"))
        builder.Connect(
            cloud.point_cloud_output_port(),
            perception.GetInputPort(f"point_cloud_{i}"),
        )
    return perception
