"""Where a scenario's obstacles are at time t, and the SceneGraph frames
that carry the moving ones (`obstacles.register_obstacles` registers them;
`systems.motion.ObstacleMotion` poses them in a flight's diagram; a
context without a diagram is posed with `ObstacleFrames.fix`)."""

import copy
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import FramePoseVector
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import moves
from mfi_drake.maths.motion import displacement


def obstacle_position(obstacle: sc.Obstacle, t=0.0) -> np.ndarray:
    """The obstacle's position at time t (t an array of N: (N, 3)); a static
    obstacle's is its `position`, unchanged."""
    position = np.asarray(obstacle.position, float)
    if not moves(obstacle.motion):
        return position if np.ndim(t) == 0 else np.tile(position, (len(t), 1))
    m = obstacle.motion
    return position + displacement(
        m.velocity, m.amplitude, m.angular_frequency, m.phase, t
    )


def obstacle_pose(obstacle: sc.Obstacle, t: float = 0.0) -> RigidTransform:
    """X_WO of a scenario obstacle at time t."""
    return RigidTransform(
        RollPitchYaw(np.radians(obstacle.rpy_deg)), obstacle_position(obstacle, t)
    )


def is_dynamic(scenario: sc.Scenario) -> bool:
    """Whether anything but the vehicle moves: an obstacle with a motion, or
    another vehicle."""
    return bool(scenario.other_vehicles) or obstacles_move(scenario)


def obstacles_move(scenario: sc.Scenario) -> bool:
    """Whether an obstacle has a motion."""
    return any(moves(o.motion) for o in scenario.obstacles)


@dataclass
class ObstacleFrames:
    """The SceneGraph frames of a scenario's moving obstacles, one each, and
    the obstacles they carry (copies: a later change of the scenario moves
    nothing)."""

    source_id: object  # the SourceId they are registered under
    frames: list  # [(FrameId, sc.Obstacle)]

    def __post_init__(self):
        self.frames = [(f, copy.deepcopy(o)) for f, o in self.frames]
        # `obstacle_pose`'s constants converted once: the poses are asked
        # for at every new time (converting them cost a sweep flight among
        # 20 obstacles, 6 moving, 15 % of its CPU); the same numbers.
        self._constants = [
            (
                frame_id,
                RotationMatrix(RollPitchYaw(np.radians(o.rpy_deg))),
                np.asarray(o.position, float),
                *(
                    np.asarray(value, float)
                    for value in (
                        o.motion.velocity,
                        o.motion.amplitude,
                        o.motion.angular_frequency,
                        o.motion.phase,
                    )
                ),
            )
            for frame_id, o in self.frames
        ]

    def poses(self, t: float) -> FramePoseVector:
        """Every frame's pose at time t (`obstacle_pose`'s)."""
        poses = FramePoseVector()
        for frame_id, rotation, position, *motion in self._constants:
            pose = RigidTransform(rotation, position + displacement(*motion, t))
            poses.set_value(frame_id, pose)
        return poses

    def fix(self, scene_graph, context, t: float) -> None:
        """Poses the frames at time t in a SceneGraph `context` that no
        diagram feeds (nothing to do without moving obstacles)."""
        if self.frames:
            port = scene_graph.get_source_pose_port(self.source_id)
            port.FixValue(context, self.poses(t))
