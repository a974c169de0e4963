"""The vehicle in SceneGraph and the paper's sphere sensor (§III)."""

import copy
import math

import numpy as np
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
    OBSTACLE_COUNT,
    POSITION,
    READING_SIZE,
    STATE_SIZE,
    signal_size,
)
from mfi_drake.world.obstacles import nearest_obstacles

VEHICLE_RGBA = Rgba(*vehicle_model.VEHICLE_RGBA)
_SHAPES = {"box": DrakeBox, "cylinder": DrakeCylinder}  # `vehicle_model.Part`'s
SLACK = 1e-3  # [m] added to a shortened reach, for the distances' rounding


class AnchoredReadings:
    """The sphere sensor's readings (`nearest_obstacles` within r_s) at
    the positions of n vehicles among anchored proximity geometry, each
    vehicle with the memo of its last reading: `SphereSensor`'s (n = 1) and
    `FleetSceneSensor`'s.

    The obstacles are anchored, so a reading depends on p and on the
    proximity geometry, which only changes with its version (read once a
    call). A position that repeats (the step's first evaluation repeats the
    logger's) costs no query; a new one is queried within the last
    reading's farthest plus the distance moved: distances are 1-Lipschitz,
    so the nearest obstacles are no farther, SceneGraph's broadphase skips
    every obstacle beyond, and the reading is the one of the full radius.
    The query object is valid only during its evaluation: not kept.
    """

    def __init__(
        self,
        radius: float,
        n: int,
        ignore: frozenset = frozenset(),
        count: int = OBSTACLE_COUNT,
    ):
        self._radius = float(radius)
        self._ignore = frozenset(ignore)
        self._count = int(count)  # readings a vehicle's signal holds
        self._version = None  # the proximity geometry's, at the last call
        self._all = (None, None)  # (every position's bytes, readings (n, 4 count))
        # A vehicle's (position bytes, reading, position as floats, distance
        # of its farthest reading or None) at its last query.
        self._last = [(None, None, None, None)] * n

    def __call__(self, query, positions: np.ndarray) -> np.ndarray:
        """The readings (n, signal_size(count)) at `positions` (n, 3)."""
        current = query.inspector().geometry_version()
        same = self._version is not None and current.IsSameAs(
            self._version, Role.kProximity
        )
        if not same:
            self._version = copy.copy(current)
        positions = np.array(positions, float)  # C-contiguous: a row's bytes
        key = positions.tobytes()
        if same and key == self._all[0]:  # every vehicle where it was
            return self._all[1]
        # Floats for math.dist, which iterates numpy rows slowly.
        points = positions.tolist()
        out = np.array(
            [self._read(k, query, p, points[k], same) for k, p in enumerate(positions)]
        )
        self._all = (key, out)
        return out

    def _read(self, k: int, query, p: np.ndarray, point: list, same: bool):
        key = p.tobytes()
        last_key, value, last_point, farthest = self._last[k]
        if same and key == last_key:
            return value
        reach = self._radius
        if same and farthest is not None:
            reach = min(reach, farthest + math.dist(point, last_point) + SLACK)
        value = nearest_obstacles(query, p, reach, self._ignore, self._count)
        if value[-1] <= 0.5 and reach < self._radius:
            value = nearest_obstacles(
                query, p, self._radius, self._ignore, self._count
            )  # never met so far
        farthest = None
        if value[-1] > 0.5:  # every reading seen: the last is the farthest
            farthest = math.hypot(*value[-READING_SIZE:-1].tolist())
        self._last[k] = (key, value, point, farthest)
        return value


class SphereSensor(LeafSystem):
    """The paper's local sensor (§III): the closest obstacle point within r_s,
    of each of the `readings` nearest obstacles (`maths.layout`).

    .. pydrake_system::

        name: SphereSensor
        input_ports:
        - query
        - state
        output_ports:
        - obstacle

    "query": SceneGraph's QueryObject; "state": the plant's 12-vector;
    "obstacle": `readings` readings [r_o, seen], nearest first.

    `moving`: whether proximity geometry moves (obstacles with a motion,
    other vehicles), which turns off the memo of the last reading
    (`AnchoredReadings`). `ignore`: GeometryIds that are no obstacle (the
    vehicle's own shapes, where it has proximity geometry in SceneGraph).
    """

    def __init__(
        self,
        radius: float,
        moving: bool = False,
        ignore=(),
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self._radius = float(radius)
        self._ignore = frozenset(ignore)
        self._count = int(readings)
        self._anchored = (
            None if moving else AnchoredReadings(radius, 1, ignore, self._count)
        )
        self._query = self.DeclareAbstractInputPort(
            "query", AbstractValue.Make(QueryObject())
        )
        self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
        self.DeclareVectorOutputPort(
            "obstacle",
            signal_size(self._count),
            self._calc,
            prerequisites_of_calc={self._query.ticket(), self._state.ticket()},
        )

    def _calc(self, context, output):
        p = self._state.Eval(context)[POSITION]
        query = self._query.Eval(context)
        if self._anchored is None:
            value = nearest_obstacles(query, p, self._radius, self._ignore, self._count)
        else:
            value = self._anchored(query, p.reshape(1, 3))[0]
        output.SetFromVector(value)


class FleetSceneSensor(LeafSystem):
    """Every vehicle's `SphereSensor` reading of the scene, in one Python
    call an evaluation for the fleet (`flight.fleet`, one integrator): each
    vehicle's reading is its own sphere sensor's, bit for bit
    (`AnchoredReadings`; with `moving`, proximity geometry that moves, a
    query at every evaluation as `SphereSensor`'s with `moving`).

    .. pydrake_system::

        name: FleetSceneSensor
        input_ports:
        - query
        - states
        output_ports:
        - scene

    "query": SceneGraph's QueryObject; "states": the n plants' states,
    stacked (12 n); "scene": each vehicle's `readings` readings
    [r_o, seen], nearest first, stacked (4 readings n).
    """

    def __init__(
        self,
        radius: float,
        n: int,
        moving: bool = False,
        readings: int = OBSTACLE_COUNT,
    ):
        super().__init__()
        self._n = int(n)
        self._radius = float(radius)
        self._count = int(readings)
        self._anchored = (
            None if moving else AnchoredReadings(radius, self._n, count=self._count)
        )
        self._query = self.DeclareAbstractInputPort(
            "query", AbstractValue.Make(QueryObject())
        )
        self._states = self.DeclareVectorInputPort("states", STATE_SIZE * self._n)
        self.DeclareVectorOutputPort(
            "scene",
            signal_size(self._count) * self._n,
            self._calc,
            prerequisites_of_calc={self._query.ticket(), self._states.ticket()},
        )

    def _calc(self, context, output):
        states = self._states.Eval(context).reshape(self._n, STATE_SIZE)
        query = self._query.Eval(context)
        if self._anchored is None:
            readings = np.concatenate(
                [
                    nearest_obstacles(
                        query, x[POSITION], self._radius, count=self._count
                    )
                    for x in states
                ]
            )
        else:
            readings = self._anchored(query, states[:, POSITION]).ravel()
        output.SetFromVector(readings)


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
