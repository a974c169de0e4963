"""The obstacles in SceneGraph, and exact distances to them.

The navigator never sees SceneGraph: sensors (`systems.sensors`,
`systems.camera`) turn geometry into the "obstacle" reading of
`maths.layout`. Here: registering a scenario's obstacles, the closest points
a sphere sensor reads, and exact distances for validation and metrics.
"""

import numpy as np
from pydrake.geometry import (
    GeometryInstance,
    IllustrationProperties,
    PerceptionProperties,
    ProximityProperties,
    RenderLabel,
    Rgba,
    SceneGraph,
)
from pydrake.math import RigidTransform, RollPitchYaw

from mfi_drake.config import scenario as sc
from mfi_drake.maths.layout import OBSTACLE_COUNT, obstacle_signal
from mfi_drake.world.shapes import drake_shape, shape_mesh

OBSTACLE_RGBA = Rgba(0.55, 0.55, 0.6, 0.6)


def obstacle_pose(obstacle: sc.Obstacle) -> RigidTransform:
    """X_WO of a scenario obstacle."""
    return RigidTransform(
        RollPitchYaw(np.radians(obstacle.rpy_deg)), np.asarray(obstacle.position, float)
    )


def obstacle_triangles(scenario: sc.Scenario, obstacle: sc.Obstacle) -> np.ndarray:
    """(M, 3, 3) world-frame triangles of an obstacle, for drawing."""
    vertices, tris = shape_mesh(scenario, obstacle.shape)
    X = obstacle_pose(obstacle)
    world = (X.rotation().matrix() @ vertices.T).T + X.translation()
    return world[tris]


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
