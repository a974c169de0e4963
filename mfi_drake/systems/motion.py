"""The source of the moving obstacles' poses in SceneGraph."""

from pydrake.common.value import AbstractValue
from pydrake.geometry import FramePoseVector
from pydrake.systems.framework import LeafSystem

from mfi_drake.world.motion import ObstacleFrames


class ObstacleMotion(LeafSystem):
    """Poses the frames of the moving obstacles at the context's time, by
    the closed form of their `motion:` (`maths.motion`), so that every
    sensor and camera sees them where they are.

    .. pydrake_system::

        name: ObstacleMotion
        output_ports:
        - geometry_pose

    "geometry_pose": a FramePoseVector for SceneGraph's pose input of the
    obstacles' source; it depends on time only.
    """

    def __init__(self, frames: ObstacleFrames):
        super().__init__()
        self._frames = ObstacleFrames(frames.source_id, frames.frames)  # a copy
        self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._calc,
            prerequisites_of_calc={self.time_ticket()},
        )

    @property
    def source_id(self):
        return self._frames.source_id

    def _calc(self, context, output):
        output.set_value(self._frames.poses(context.get_time()))
