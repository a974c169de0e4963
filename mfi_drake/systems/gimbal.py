"""The gimbal that carries a depth camera: a SceneGraph frame posed from the
vehicle's true body pose and the gimbal's angles, which the camera's
perception commands (`camera.DepthCameraSensor`, output "gimbal_angles").

    VehicleGeometry ──body_pose──▶ GimbalPose "gimbal" ──geometry_pose──▶ SceneGraph
    DepthCameraSensor ──gimbal_angles──┘                (frame "gimbal")

The gimbal is stabilised in the world: its frame G sits at a fixed point of
the body and has the orientation `maths.gimbal.gimbal_rotation(pan, tilt)`,
whatever the body's attitude (an ideal stabiliser; the slew-rate limit is in
the commanded angles).
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import FrameId, FramePoseVector, GeometryFrame, SceneGraph
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import LeafSystem

from mfi_drake.maths.gimbal import gimbal_rotation


class GimbalPose(LeafSystem):
    """The gimbal frame's pose in SceneGraph.

    .. pydrake_system::

        name: GimbalPose
        input_ports:
        - body_pose
        - gimbal_angles
        output_ports:
        - geometry_pose

    "body_pose": the vehicle's FramePoseVector (its body frame `body_id`);
    "gimbal_angles": (pan, tilt) [rad]; "geometry_pose": the pose of
    `frame_id`, at `p_BG` on the body, for SceneGraph's source `source_id`.
    """

    def __init__(
        self, scene_graph: SceneGraph, body_id: FrameId, p_BG, name: str = "gimbal"
    ):
        super().__init__()
        self._body_id = body_id
        self._p_BG = np.asarray(p_BG, dtype=float)
        self.source_id = scene_graph.RegisterSource(name)
        self.frame_id = scene_graph.RegisterFrame(
            self.source_id, GeometryFrame("gimbal")
        )
        self._body = self.DeclareAbstractInputPort(
            "body_pose", AbstractValue.Make(FramePoseVector())
        )
        self._angles = self.DeclareVectorInputPort("gimbal_angles", 2)
        self.DeclareAbstractOutputPort(
            "geometry_pose", lambda: AbstractValue.Make(FramePoseVector()), self._calc
        )

    def _calc(self, context, output):
        X_WB = self._body.Eval(context).value(self._body_id)
        pan, tilt = self._angles.Eval(context)
        poses = output.get_mutable_value()
        poses.clear()
        poses.set_value(
            self.frame_id,
            RigidTransform(
                RotationMatrix(gimbal_rotation(pan, tilt)), X_WB @ self._p_BG
            ),
        )
