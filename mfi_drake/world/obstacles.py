"""The obstacles in SceneGraph, and exact distances to them.

The navigator never sees SceneGraph: sensors (`systems.sensors`,
`systems.camera`) turn geometry into the "obstacle" reading of
`maths.layout`. Here: registering a scenario's obstacles and ground, the
closest points a sphere sensor reads, and exact distances for validation and
metrics (at the logged times, where obstacles move).
"""

import dataclasses
import logging

import numpy as np
from pydrake.geometry import Box as DrakeBox
from pydrake.geometry import (
    GeometryFrame,
    GeometryInstance,
    IllustrationProperties,
    PerceptionProperties,
    ProximityProperties,
    RenderLabel,
    Rgba,
    SceneGraph,
)
from pydrake.math import RigidTransform

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import moves
from mfi_drake.maths.layout import OBSTACLE_COUNT, nearest_first, obstacle_signal
from mfi_drake.maths.point_maps import nearest_points
from mfi_drake.world.motion import ObstacleFrames, obstacle_pose
from mfi_drake.world.shapes import bounding_radius, drake_shape, shape_mesh

OBSTACLE_RGBA = Rgba(0.55, 0.55, 0.6, 0.6)
GROUND_RGBA = Rgba(0.45, 0.6, 0.4, 1.0)
# [m] The ground is a box this wide and deep whose top face is the ground
# plane, not Drake's HalfSpace: FCL gives a half space an AABB reaching to
# ±DBL_MAX, on which its broadphase tree (built over the anchored geometry)
# does arithmetic that overflows; with ~100 or more other geometries the
# tree comes out corrupt and SceneGraph's copy of it (every new context)
# crashes with a segmentation fault (Drake issue #19263, FCL's
# DynamicAABBTreeCollisionManager; docs/performance.md, "Big scenes"). Above
# the box, within its width, its distance is the half space's, exactly:
# the top face's. The depth keeps the rounding of that distance at ~1e-14 m.
GROUND_WIDTH = 2.0e4
GROUND_DEPTH = 100.0


def obstacle_triangles(
    scenario: sc.Scenario, obstacle: sc.Obstacle, t: float = 0.0
) -> np.ndarray:
    """(M, 3, 3) world-frame triangles of an obstacle at time t, for drawing."""
    vertices, tris = shape_mesh(scenario, obstacle.shape)
    X = obstacle_pose(obstacle, t)
    world = (X.rotation().matrix() @ vertices.T).T + X.translation()
    return world[tris]


class _HalfSpaceNotice(logging.Filter):
    """Drops Drake's one notice that half spaces take no part in deformable
    contact (there is no contact here: the ground is sensed and measured)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "half spaces are not currently supported" not in record.getMessage()


_HALF_SPACE_NOTICE = _HalfSpaceNotice()


def quiet_half_spaces() -> None:
    """Drake's notice about half spaces is not shown (a second call adds
    nothing: a logger holds a filter once)."""
    logging.getLogger("drake").addFilter(_HALF_SPACE_NOTICE)


def register_obstacles(
    scene_graph: SceneGraph, scenario: sc.Scenario
) -> ObstacleFrames:
    """Registers every obstacle with the proximity (sphere sensor,
    clearance), perception (depth camera) and illustration roles: a static
    one as anchored geometry, a moving one on a frame of its own, whose
    poses the returned `ObstacleFrames` gives. The ground is an anchored
    box under the ground plane (GROUND_WIDTH: not a HalfSpace), sensed and
    measured but not illustrated (`app.animation` draws it)."""
    source = scene_graph.RegisterSource("obstacles")
    moving = []
    for i, obstacle in enumerate(scenario.obstacles):
        frame, pose = None, obstacle_pose(obstacle)
        if moves(obstacle.motion):  # the frame carries the pose
            frame = scene_graph.RegisterFrame(source, GeometryFrame(f"obstacle_{i}"))
            moving.append((frame, obstacle))
            pose = RigidTransform()
        instance = GeometryInstance(
            pose, drake_shape(scenario, obstacle.shape), f"obstacle_{i}"
        )
        sensed(instance, OBSTACLE_RGBA, RenderLabel(i + 1))
        illustration = IllustrationProperties()
        illustration.AddProperty("phong", "diffuse", OBSTACLE_RGBA)
        instance.set_illustration_properties(illustration)
        if frame is None:
            scene_graph.RegisterAnchoredGeometry(source, instance)
        else:
            scene_graph.RegisterGeometry(source, frame, instance)
    if scenario.ground is not None:
        ground = GeometryInstance(
            RigidTransform([0.0, 0.0, scenario.ground.height - GROUND_DEPTH / 2]),
            DrakeBox(GROUND_WIDTH, GROUND_WIDTH, GROUND_DEPTH),
            "ground",
        )
        sensed(ground, GROUND_RGBA, RenderLabel(len(scenario.obstacles) + 1))
        scene_graph.RegisterAnchoredGeometry(source, ground)
    return ObstacleFrames(source, moving)


def sensed(instance: GeometryInstance, rgba: Rgba, label: RenderLabel) -> None:
    """The proximity role (sphere sensor, clearance) and the perception role
    (depth camera) of an obstacle, the ground or a vehicle's sphere."""
    instance.set_proximity_properties(ProximityProperties())
    perception = PerceptionProperties()
    perception.AddProperty("phong", "diffuse", rgba)
    perception.AddProperty("label", "id", label)
    instance.set_perception_properties(perception)


def nearest_obstacles(
    query_object,
    p: np.ndarray,
    threshold: float,
    ignore: frozenset = frozenset(),
    count: int = OBSTACLE_COUNT,
) -> np.ndarray:
    """The "obstacle" signal of `count` readings: the closest point of each
    of the `count` proximity geometries nearest to p within `threshold`,
    but those whose GeometryId is in `ignore` (a vehicle's own geometry).

    Uses SceneGraph's ComputeSignedDistanceToPoint: the closest point is
    p − d ∇d (∇d is the outward gradient), so r_o = −d ∇d. Every proximity
    geometry is an obstacle: in a scenario's diagram the obstacles, the
    ground and other vehicles' spheres; in a user's, whatever they
    registered.
    """
    results = query_object.ComputeSignedDistanceToPoint(p, threshold)
    if ignore:
        results = [r for r in results if r.id_G not in ignore]
    distances = [r.distance for r in results]
    points = []
    for i in nearest_first(distances, count):
        # In floats, (−d) g_i as numpy would multiply it, without numpy's
        # cost a product (~1 µs a reading).
        d, (x, y, z) = -distances[i], results[i].grad_W.tolist()
        points.append((d * x, d * y, d * z))
    return obstacle_signal(points, count)


def obstacle_distances(
    scenario: sc.Scenario, points, within: float = np.inf, times=None
) -> list[float]:
    """Exact signed distance from each point to the nearest obstacle surface
    or the ground, with the obstacles where they are at the point's time
    (`times`, one per point; default t = 0); inf when nothing is within
    `within` (SceneGraph's broadphase then skips the far obstacles, which is
    what makes a threshold cheap). A point-cloud map's points count as
    surfaces (`Scenario.map_points`)."""
    found = [d for d, _ in _nearest(scenario, points, within, times)]
    if scenario.map_points:
        to_map, _ = nearest_points(np.asarray(scenario.map_points), points)
        to_map[to_map > within] = np.inf
        found = np.minimum(found, to_map).tolist()
    return found


def closest_obstacles(
    scenario: sc.Scenario, points
) -> list[tuple[float, sc.Obstacle | None]]:
    """As `obstacle_distances` at t = 0, with the obstacle each distance is
    to (None: the ground, or nothing)."""
    out = [
        (d, None if i is None else scenario.obstacles[i])
        for d, i in _nearest(scenario, points, np.inf, None)
    ]
    if scenario.map_points:  # the nearer of the map and the obstacles
        map_points = np.asarray(scenario.map_points)
        to_map, index = nearest_points(map_points, points)
        for k, m in enumerate(to_map):
            if m < out[k][0]:
                nearest = [round(float(x), 3) for x in map_points[index[k]]]
                name = f"the map's point {nearest}"
                out[k] = (float(m), sc.Obstacle(position=nearest, name=name))
    return out


# [m] added to the bounds `_candidates` compares: distances from Drake and
# from the bounding balls round differently.
_BOUND_SLACK = 1e-6
_CHUNK = 1 << 22  # point–obstacle pairs `_candidates` compares at once


def _candidates(scenario: sc.Scenario, points: np.ndarray, within: float):
    """(the obstacles that can be nearest one of `points` at t = 0, each
    point's bound on its nearest distance): an obstacle is within the ball
    of its bounding radius about its origin, so the nearest is no farther
    than the least |p − c| + ρ (or the ground's z − h), and one whose
    |p − c| − ρ exceeds that for every point is never nearest. Asking
    SceneGraph about the candidates alone, each point within its bound,
    gives the same answers at a cost that grows with the obstacles near
    the points, not with the scene (SceneGraph's registration of n
    geometries costs ~n² on Drake 1.51: docs/performance.md, "Big
    scenes")."""
    obstacles = scenario.obstacles
    bound = np.full(len(points), float(within))
    if scenario.ground is not None:
        bound = np.minimum(bound, points[:, 2] - scenario.ground.height)
    if not obstacles:
        return [], bound
    centres = np.array([obstacle_pose(o).translation() for o in obstacles])
    radii = np.array([bounding_radius(scenario, o.shape) for o in obstacles])
    near = np.zeros(len(obstacles), dtype=bool)
    step = max(1, _CHUNK // len(obstacles))
    for lo in range(0, len(points), step):
        gap = np.linalg.norm(points[lo : lo + step, None] - centres[None], axis=2)
        chunk = np.minimum(bound[lo : lo + step], (gap + radii).min(axis=1))
        bound[lo : lo + step] = chunk
        near |= (gap - radii <= chunk[:, None] + _BOUND_SLACK).any(axis=0)
    return np.flatnonzero(near).tolist(), bound


def _nearest(scenario: sc.Scenario, points, within: float, times):
    """(the signed distance to the nearest obstacle or the ground, the
    obstacle's index in `scenario.obstacles` or None for the ground) for
    each point, with the obstacles where they are at its time; (inf,
    None) where nothing is within `within`. At t = 0 (or with nothing
    moving) only the `_candidates` are registered."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    moving = times is not None and any(moves(o.motion) for o in scenario.obstacles)
    kept = list(range(len(scenario.obstacles)))
    limits = np.full(len(points), float(within))
    if not moving:
        kept, bounds = _candidates(scenario, points, within)
        limits = np.minimum(bounds + _BOUND_SLACK, within)
        scenario = dataclasses.replace(
            scenario, obstacles=[scenario.obstacles[i] for i in kept]
        )
    scene_graph = SceneGraph()
    frames = register_obstacles(scene_graph, scenario)
    context = scene_graph.CreateDefaultContext()
    port = scene_graph.get_query_output_port()
    frames.fix(scene_graph, context, 0.0)
    query = port.Eval(context)
    inspector = query.inspector()
    for k, p in enumerate(points):
        if frames.frames and times is not None:
            frames.fix(scene_graph, context, times[k])
            query = port.Eval(context)
        results = query.ComputeSignedDistanceToPoint(p, limits[k])
        r = min(results, key=lambda r: r.distance, default=None)
        if r is None or r.distance > within:
            yield np.inf, None
            continue
        name = inspector.GetName(r.id_G)  # "obstacle_<i>" or "ground"
        index = name.removeprefix("obstacle_")
        yield r.distance, kept[int(index)] if index != name else None
