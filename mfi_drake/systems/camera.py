"""The on-board depth camera of the Pelican runs (paper §VI-B).

Drake's `RgbdSensor`, fixed to the vehicle's body frame, renders a depth
image with the VTK engine (headless, EGL). `DepthCameraSensor` back-projects
its pixels into a point cloud, keeps the point closest to the vehicle centre
and feeds the navigator the same "obstacle" signal as the sphere sensor
(see `maths.layout`), with that one point as its only reading (the cloud is not
split into obstacles). Pixels beyond max_range are "no return"; an
image without returns means nothing is seen, and nothing seen earlier is
remembered.

The camera renders at its own rate: a periodic discrete update evaluates the
depth image, which is the only place it is evaluated, and holds the closest
point (world frame) until the next frame. Between frames the output is
r_o = p_o − p(t): the held point seen from the vehicle's current position.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    ClippingRange,
    DepthRange,
    DepthRenderCamera,
    MakeRenderEngineVtk,
    RenderCameraCore,
    RenderEngineVtkParams,
    SceneGraph,
)
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.sensors import CameraInfo, ImageDepth32F, RgbdSensor

from mfi_drake.config.scenario import MIN_DEPTH, DepthCamera
from mfi_drake.maths.layout import (
    OBSTACLE_SIGNAL_SIZE,
    POSITION,
    STATE_SIZE,
    obstacle_signal,
)
from mfi_drake.systems.sensors import VehicleGeometry

RENDERER = "vtk"
NEAR_CLIP = 0.01  # m, the renderer's near clipping plane

# Drake's camera frame C looks along +z with +x to the image's right and +y
# down. The scenario gives the camera's orientation for a "look" frame L that,
# like the body, has +x forward and +z up; R_LC maps one to the other.
R_LC = RotationMatrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))


def camera_pose_on_body(camera: DepthCamera) -> RigidTransform:
    """X_BC: the camera frame C on the body B from the scenario's position and
    rpy_deg (zero rpy: looking along the body's +x, image up = body +z)."""
    R_BL = RollPitchYaw(np.radians(camera.rpy_deg)).ToRotationMatrix()
    return RigidTransform(R_BL @ R_LC, np.asarray(camera.position, float))


def camera_info(camera: DepthCamera) -> CameraInfo:
    """Square pixels, principal point at the image centre."""
    return CameraInfo(camera.width, camera.height, np.radians(camera.fov_y_deg))


def pixel_rays(
    width: int,
    height: int,
    focal_x: float,
    focal_y: float,
    center_x: float,
    center_y: float,
) -> np.ndarray:
    """(height·width, 3) rays in the camera frame, row-major like the image,
    scaled so that their z is 1: pixel (u, v) at depth z is the point
    z · [(u − c_x)/f_x, (v − c_y)/f_y, 1] (pinhole back-projection)."""
    u, v = np.meshgrid(np.arange(width), np.arange(height))
    rays = np.stack(
        [(u - center_x) / focal_x, (v - center_y) / focal_y, np.ones(u.shape)], axis=-1
    )
    return rays.reshape(-1, 3)


def closest_return(
    depth: np.ndarray, rays: np.ndarray, R_WC: np.ndarray, p_WC: np.ndarray, p
) -> np.ndarray:
    """[p_o (3), seen]: the world point of the depth image closest to p
    (the paper's reading: the point cloud is not split into obstacles).

    depth holds z-depths [m] (inf: no return; 0: closer than MIN_DEPTH, taken
    as MIN_DEPTH). Each return is back-projected, z·ray, and moved to the
    world by the camera pose (R_WC, p_WC). Without returns: zeros, seen 0.
    """
    z = np.asarray(depth, float).reshape(-1)
    hit = np.isfinite(z)
    if not hit.any():
        return np.zeros(4)
    z = np.maximum(z[hit], MIN_DEPTH)
    points_W = (z[:, None] * rays[hit]) @ np.asarray(R_WC).T + p_WC
    closest = np.argmin(np.sum((points_W - p) ** 2, axis=1))
    return np.append(points_W[closest], 1.0)


class DepthCameraSensor(LeafSystem):
    """Closest point of the depth camera's point cloud, held between frames.

    .. pydrake_system::

        name: DepthCameraSensor
        input_ports:
        - depth_image
        - camera_pose
        - state
        output_ports:
        - obstacle
        - frames_rendered

    "depth_image": ImageDepth32F; "camera_pose": X_WC, a RigidTransform;
    "state": the plant's 12-vector. "obstacle": one reading [p_o − p, seen],
    the others unseen; "frames_rendered": frames rendered so far (a state).
    Discrete state: the held [p_o, seen] and the number of frames rendered.
    """

    def __init__(self, info: CameraInfo, rate_hz: float):
        super().__init__()
        self._rays = pixel_rays(
            info.width(),
            info.height(),
            info.focal_x(),
            info.focal_y(),
            info.center_x(),
            info.center_y(),
        )
        self._depth = self.DeclareAbstractInputPort(
            "depth_image", AbstractValue.Make(ImageDepth32F())
        )
        self._pose = self.DeclareAbstractInputPort(
            "camera_pose", AbstractValue.Make(RigidTransform())
        )
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self._held = self.DeclareDiscreteState(4)
        self._frames = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("frames_rendered", self._frames)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / rate_hz, 0.0, self._render)
        self.DeclareVectorOutputPort(
            "obstacle",
            OBSTACLE_SIGNAL_SIZE,
            self._calc,
            prerequisites_of_calc={
                self.discrete_state_ticket(self._held),
                self._state.ticket(),
            },
        )

    def sense(self, context) -> np.ndarray:
        """Renders one frame now and returns [p_o, seen] (world frame)."""
        depth = self._depth.Eval(context).data
        X_WC = self._pose.Eval(context)
        p = self._state.Eval(context)[POSITION]
        return closest_return(
            depth, self._rays, X_WC.rotation().matrix(), X_WC.translation(), p
        )

    def _frame_count(self, context) -> int:
        return int(context.get_discrete_state(self._frames).GetAtIndex(0))

    def _render(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._held).SetFromVector(self.sense(context))
        discrete_state.get_mutable_vector(self._frames).SetAtIndex(
            0, self._frame_count(context) + 1.0
        )

    def _calc(self, context, output):
        held = context.get_discrete_state(self._held).get_value()
        if held[3] <= 0.5:
            output.SetFromVector(obstacle_signal([]))
            return
        p = self._state.Eval(context)[POSITION]
        output.SetFromVector(obstacle_signal([held[:3] - p]))


def add_depth_camera(
    builder: DiagramBuilder,
    camera: DepthCamera,
    scene_graph: SceneGraph,
    state_port,
    geometry: VehicleGeometry,
) -> DepthCameraSensor:
    """Adds the VTK renderer, an RgbdSensor on the vehicle's body frame and the
    DepthCameraSensor "sensor" fed by it; returns the latter."""
    scene_graph.AddRenderer(RENDERER, MakeRenderEngineVtk(RenderEngineVtkParams()))
    info = camera_info(camera)
    core = RenderCameraCore(
        RENDERER,
        info,
        ClippingRange(NEAR_CLIP, 1.5 * camera.max_range),
        RigidTransform(),
    )
    rgbd = builder.AddNamedSystem(
        "rgbd_sensor",
        RgbdSensor(
            geometry.frame_id,
            camera_pose_on_body(camera),
            DepthRenderCamera(core, DepthRange(MIN_DEPTH, camera.max_range)),
        ),
    )
    builder.Connect(scene_graph.get_query_output_port(), rgbd.query_object_input_port())
    sensor = builder.AddNamedSystem("sensor", DepthCameraSensor(info, camera.rate_hz))
    builder.Connect(
        rgbd.depth_image_32F_output_port(), sensor.GetInputPort("depth_image")
    )
    builder.Connect(
        rgbd.body_pose_in_world_output_port(), sensor.GetInputPort("camera_pose")
    )
    builder.Connect(state_port, sensor.GetInputPort("state"))
    return sensor
