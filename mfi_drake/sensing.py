"""Obstacles in SceneGraph, the vehicle's own geometry, and the sphere sensor.

The navigator never sees SceneGraph: sensors turn geometry into the
"obstacle" signal: OBSTACLE_COUNT readings [r_o (3), seen], nearest first,
r_o being the vector from the vehicle centre to an obstacle's closest point
(world frame, m) and seen 1.0 when that obstacle is in range, else 0.0
(with r_o = 0). The paper senses the closest point only; the navigator adds
the fields of the nearest few obstacles (see `systems.ObstacleNavigator`).
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box as DrakeBox,
)
from pydrake.geometry import (
    Capsule as DrakeCapsule,
)
from pydrake.geometry import (
    Convex as DrakeConvex,
)
from pydrake.geometry import (
    Cylinder as DrakeCylinder,
)
from pydrake.geometry import (
    Ellipsoid as DrakeEllipsoid,
)
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    IllustrationProperties,
    PerceptionProperties,
    ProximityProperties,
    RenderLabel,
    Rgba,
    SceneGraph,
)
from pydrake.geometry import (
    Sphere as DrakeSphere,
)
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import LeafSystem

from mfi_drake import scenario as sc
from mfi_drake.last_result import LastResult
from mfi_drake.meshes import obstacle_pose

OBSTACLE_COUNT = 3  # obstacles a reading reports, nearest first
OBSTACLE_SIGNAL_SIZE = 4 * OBSTACLE_COUNT
OBSTACLE_RGBA = Rgba(0.55, 0.55, 0.6, 0.6)
VEHICLE_RGBA = Rgba(0.1, 0.3, 0.8, 1.0)


def drake_shape(scenario: sc.Scenario, shape):
    """The pydrake.geometry shape of a scenario shape."""
    if isinstance(shape, sc.Box):
        return DrakeBox(*shape.size)
    if isinstance(shape, sc.Sphere):
        return DrakeSphere(shape.radius)
    if isinstance(shape, sc.Cylinder):
        return DrakeCylinder(shape.radius, shape.length)
    if isinstance(shape, sc.Capsule):
        return DrakeCapsule(shape.radius, shape.length)
    if isinstance(shape, sc.Ellipsoid):
        return DrakeEllipsoid(*shape.radii)
    if isinstance(shape, sc.Convex):
        return DrakeConvex(sc.mesh_path(scenario, shape), shape.scale)
    raise TypeError(f"unknown shape {shape!r}")


def register_obstacles(scene_graph: SceneGraph, scenario: sc.Scenario) -> None:
    """Registers every obstacle as anchored geometry with the proximity
    (sphere sensor, clearance), perception (depth camera) and illustration
    roles."""
    source = scene_graph.RegisterSource("obstacles")
    for i, obstacle in enumerate(scenario.obstacles):
        instance = GeometryInstance(
            obstacle_pose(obstacle),
            drake_shape(scenario, obstacle.shape),
            f"obstacle_{i}",
        )
        instance.set_proximity_properties(ProximityProperties())
        perception = PerceptionProperties()
        perception.AddProperty("phong", "diffuse", OBSTACLE_RGBA)
        perception.AddProperty("label", "id", RenderLabel(i + 1))
        instance.set_perception_properties(perception)
        illustration = IllustrationProperties()
        illustration.AddProperty("phong", "diffuse", OBSTACLE_RGBA)
        instance.set_illustration_properties(illustration)
        scene_graph.RegisterAnchoredGeometry(source, instance)


def obstacle_signal(points) -> np.ndarray:
    """The "obstacle" signal from up to OBSTACLE_COUNT vectors r_o, nearest
    first; the readings not filled are "nothing seen"."""
    out = np.zeros(OBSTACLE_SIGNAL_SIZE)
    for i, r_o in enumerate(points[:OBSTACLE_COUNT]):
        out[4 * i : 4 * i + 3] = r_o
        out[4 * i + 3] = 1.0
    return out


def nearest_obstacles(query_object, p: np.ndarray, threshold: float) -> np.ndarray:
    """The "obstacle" signal: the closest point of each of the
    OBSTACLE_COUNT proximity geometries nearest to p within `threshold`.

    Uses SceneGraph's ComputeSignedDistanceToPoint: the closest point is
    p − d ∇d (∇d is the outward gradient), so r_o = −d ∇d. Only obstacles
    carry the proximity role, so the vehicle never sees itself.
    """
    results = query_object.ComputeSignedDistanceToPoint(p, threshold)
    nearest = sorted(results, key=lambda r: r.distance)[:OBSTACLE_COUNT]
    return obstacle_signal([-r.distance * r.grad_W for r in nearest])


def obstacle_distances(
    scenario: sc.Scenario, points, within: float = np.inf
) -> list[float]:
    """Exact signed distance from each point to the nearest obstacle surface;
    inf when no obstacle is within `within` (SceneGraph's broadphase then
    skips the far obstacles, which is what makes a threshold cheap)."""
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    context = scene_graph.CreateDefaultContext()
    query = scene_graph.get_query_output_port().Eval(context)
    out = []
    for p in points:
        results = query.ComputeSignedDistanceToPoint(np.asarray(p, float), within)
        out.append(min((r.distance for r in results), default=np.inf))
    return out


class SphereSensor(LeafSystem):
    """The paper's local sensor (§III): the closest obstacle point within r_s,
    of each of the OBSTACLE_COUNT nearest obstacles.

    Inputs: "query" (SceneGraph QueryObject), "state" (the plant's 12-vector).
    Output: "obstacle" (OBSTACLE_COUNT readings [r_o, seen]).
    """

    def __init__(self, radius: float):
        super().__init__()
        self._radius = radius
        self._last = LastResult()
        self._query = self.DeclareAbstractInputPort(
            "query", SceneGraph().get_query_output_port().Allocate()
        )
        self._state = self.DeclareVectorInputPort("state", 12)
        self.DeclareVectorOutputPort(
            "obstacle",
            OBSTACLE_SIGNAL_SIZE,
            self._calc,
            prerequisites_of_calc={
                self._query.ticket(),
                self._state.ticket(),
            },
        )

    def _calc(self, context, output):
        p = self._state.Eval(context)[:3]
        query = self._query.Eval(context)
        # Keyed on p alone (the obstacles are anchored); the query object is
        # not kept, it is only valid during this evaluation.
        output.SetFromVector(
            self._last(p.tobytes(), nearest_obstacles, query, p, self._radius)
        )


class VehicleGeometry(LeafSystem):
    """Registers the vehicle's body frame and a visual shape with SceneGraph
    and moves the frame with the plant's state.

    The shapes carry only the illustration role: the vehicle is drawn, but
    neither the sphere sensor nor a camera can see it.
    """

    def __init__(
        self,
        scene_graph: SceneGraph,
        arm_length: float,
        rotor_radius: float,
        rgba: Rgba = VEHICLE_RGBA,
    ):
        super().__init__()
        self._source = scene_graph.RegisterSource("vehicle")
        self.frame_id = scene_graph.RegisterFrame(self._source, GeometryFrame("body"))
        parts = [(RigidTransform(), DrakeBox(0.6 * arm_length, 0.6 * arm_length, 0.05))]
        for k in range(4):
            angle = k * np.pi / 2
            arm_pose = RigidTransform(
                RollPitchYaw(0.0, 0.0, angle),
                [
                    0.5 * arm_length * np.cos(angle),
                    0.5 * arm_length * np.sin(angle),
                    0.0,
                ],
            )
            parts.append((arm_pose, DrakeBox(arm_length, 0.02, 0.02)))
            rotor_pose = RigidTransform(
                [arm_length * np.cos(angle), arm_length * np.sin(angle), 0.03]
            )
            parts.append((rotor_pose, DrakeCylinder(rotor_radius, 0.01)))
        for i, (pose, shape) in enumerate(parts):
            instance = GeometryInstance(pose, shape, f"vehicle_{i}")
            illustration = IllustrationProperties()
            illustration.AddProperty("phong", "diffuse", rgba)
            instance.set_illustration_properties(illustration)
            scene_graph.RegisterGeometry(self._source, self.frame_id, instance)
        self._state = self.DeclareVectorInputPort("state", 12)
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
