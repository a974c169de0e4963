"""The vehicle in SceneGraph and the paper's sphere sensor (§III)."""

import copy
import math

from pydrake.common.value import AbstractValue
from pydrake.geometry import Box as DrakeBox
from pydrake.geometry import Cylinder as DrakeCylinder
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    IllustrationProperties,
    QueryObject,
    Rgba,
    Role,
    SceneGraph,
)
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import LeafSystem

from mfi_drake.config import vehicle_model
from mfi_drake.config.vehicle_model import vehicle_parts
from mfi_drake.maths.layout import (
    OBSTACLE_SIGNAL_SIZE,
    POSITION,
    STATE_SIZE,
    readings,
)
from mfi_drake.world.obstacles import nearest_obstacles

VEHICLE_RGBA = Rgba(*vehicle_model.VEHICLE_RGBA)
_SHAPES = {"box": DrakeBox, "cylinder": DrakeCylinder}  # `vehicle_model.Part`'s
SLACK = 1e-3  # [m] added to a shortened reach, for the distances' rounding


class SphereSensor(LeafSystem):
    """The paper's local sensor (§III): the closest obstacle point within r_s,
    of each of the OBSTACLE_COUNT nearest obstacles (`maths.layout`).

    .. pydrake_system::

        name: SphereSensor
        input_ports:
        - query
        - state
        output_ports:
        - obstacle

    "query": SceneGraph's QueryObject; "state": the plant's 12-vector;
    "obstacle": OBSTACLE_COUNT readings [r_o, seen], nearest first.

    `moving`: whether proximity geometry moves (obstacles with a motion,
    other vehicles), which turns off the memo of the last reading.
    `ignore`: GeometryIds that are no obstacle (the vehicle's own shapes,
    where it has proximity geometry in SceneGraph).
    """

    def __init__(self, radius: float, moving: bool = False, ignore=()):
        super().__init__()
        self._radius = float(radius)
        self._moving = bool(moving)
        self._ignore = frozenset(ignore)
        # (position bytes, geometry version, reading, position), see _calc
        self._last = (None, None, None, None)
        self._query = self.DeclareAbstractInputPort(
            "query", AbstractValue.Make(QueryObject())
        )
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self.DeclareVectorOutputPort(
            "obstacle",
            OBSTACLE_SIGNAL_SIZE,
            self._calc,
            prerequisites_of_calc={self._query.ticket(), self._state.ticket()},
        )

    def _calc(self, context, output):
        p = self._state.Eval(context)[POSITION]
        query = self._query.Eval(context)
        if self._moving:
            output.SetFromVector(
                nearest_obstacles(query, p, self._radius, self._ignore)
            )
            return
        # The obstacles are anchored, so the reading depends on p and on the
        # proximity geometry, which only changes with its version; the
        # version is read only when p repeats (the step's first evaluation
        # repeats the logger's). The query object is valid only during this
        # evaluation: not kept.
        key = p.tobytes()
        last_key, version, value, last_p = self._last
        if key == last_key and query.inspector().geometry_version().IsSameAs(
            version, Role.kProximity
        ):
            output.SetFromVector(value)
            return
        current = query.inspector().geometry_version()
        reach = self._radius
        farthest, seen = readings(value)[-1] if value is not None else (None, 0.0)
        if seen > 0.5 and current.IsSameAs(version, Role.kProximity):
            # The nearest obstacles are no farther than the last reading's
            # farthest plus the distance moved (distances are 1-Lipschitz):
            # that reach lets SceneGraph's broadphase skip every obstacle
            # beyond it, and the reading is the one of the full radius.
            reach = min(reach, math.hypot(*farthest) + math.dist(p, last_p) + SLACK)
        value = nearest_obstacles(query, p, reach, self._ignore)
        if readings(value)[-1][1] <= 0.5 and reach < self._radius:
            value = nearest_obstacles(
                query, p, self._radius, self._ignore
            )  # never met so far
        self._last = (key, copy.copy(current), value, p.copy())
        output.SetFromVector(value)


class VehicleGeometry(LeafSystem):
    """Registers the vehicle's body frame with SceneGraph, the parts the
    shipped SDFormat models draw (`config.vehicle_model.vehicle_parts`) on
    it, and moves the frame with the plant's state.

    .. pydrake_system::

        name: VehicleGeometry
        input_ports:
        - state
        output_ports:
        - geometry_pose

    The shapes carry only the illustration role: the vehicle is drawn, but
    neither the sphere sensor nor a camera can see it (the other vehicles
    of a fleet see it as a sphere of their own diagram,
    `systems.exchange`). `name`: its SceneGraph source's.
    """

    def __init__(
        self,
        scene_graph: SceneGraph,
        arm_length: float,
        rotor_radius: float,
        rgba: Rgba = VEHICLE_RGBA,
        name: str = "vehicle",
    ):
        super().__init__()
        self._source = scene_graph.RegisterSource(name)
        self.frame_id = scene_graph.RegisterFrame(self._source, GeometryFrame("body"))
        parts = vehicle_parts(arm_length, rotor_radius)  # the SDF models' parts
        for i, part in enumerate(parts):
            instance = GeometryInstance(
                RigidTransform(RollPitchYaw(0.0, 0.0, part.yaw), part.xyz),
                _SHAPES[part.shape](*part.size),
                f"vehicle_{i}",
            )
            illustration = IllustrationProperties()
            illustration.AddProperty("phong", "diffuse", rgba)
            instance.set_illustration_properties(illustration)
            scene_graph.RegisterGeometry(self._source, self.frame_id, instance)
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._calc,
            prerequisites_of_calc={self._state.ticket()},
        )

    @property
    def source_id(self):
        return self._source

    def _calc(self, context, output):
        x = self._state.Eval(context)
        # Three scalars and a RotationMatrix pick pydrake's overloads at once;
        # a vector and a RollPitchYaw make it try (and reject) several first.
        rotation = RollPitchYaw(x[3], x[4], x[5]).ToRotationMatrix()
        output.get_mutable_value().set_value(
            self.frame_id, RigidTransform(rotation, x[:3])
        )
