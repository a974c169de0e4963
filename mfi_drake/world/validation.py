"""Loading a scenario that can be flown: `config.scenario`'s checks plus the
geometric ones (readable convex meshes; every vehicle's start and goal in
free space with room for the vehicle, above the ground, and apart from the
other vehicles').

Moving obstacles are judged where they are when it matters: a start must be
clear of every obstacle at t = 0; a goal is refused where a static obstacle
covers it, or a moving one covers it for the whole flight; a moving
obstacle over a goal at t = 0 that moves away gives a `ScenarioWarning`."""

import dataclasses
import os
import warnings

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import moves
from mfi_drake.config.scenario_yaml import layered_name, parse_scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.world.meshes import enclosed_volume, read_obj
from mfi_drake.world.obstacles import closest_obstacles, obstacle_distances
from mfi_drake.world.shapes import convex_points, shape_mesh
from mfi_drake.world.world_files import with_files

# [m] a goal's least room beyond the vehicle's collision radius: every
# method's terminal approach (docs/goals.md) settles at a goal with at least
# this much clearance; the family of tests/test_goals.py flies it.
GOAL_MARGIN = 0.025
# [m] distances are compared this much short of what is needed: SceneGraph's
# distance to a sphere whose surface is placed exactly at the margin comes
# out a few ulps short.
ROUNDING = 1e-9


def least_goal_gap(vehicle: str = "drake_default") -> float:
    """The least distance [m] from a goal to a surface that the loader accepts
    for `vehicle`: its collision radius plus GOAL_MARGIN."""
    return as_vehicle(vehicle).collision_radius + GOAL_MARGIN


GOAL_SAMPLES = 200  # times over the flight at which a moving obstacle is judged


def _check_mesh(where: str, scenario: sc.Scenario, shape: sc.Convex) -> None:
    """A readable mesh file or inline vertices, spanning a volume."""
    name, value = "shape.vertices", shape.vertices
    if shape.file:
        name, value, path = "shape.file", shape.file, sc.mesh_path(scenario, shape)
        if not os.path.isfile(path):
            sc.fail(where, name, value, f"no such file ({path})")
    try:  # the file read once: its triangles tell whether it is convex
        vertices, triangles = (
            read_obj(path) if shape.file else (convex_points(shape, ""), None)
        )
    except ValueError as e:
        sc.fail(where, name, value, str(e))
    centred = vertices - vertices.mean(axis=0)
    if len(vertices) < 4 or np.linalg.matrix_rank(centred, tol=1e-9) < 3:
        sc.fail(where, name, value, "needs 4+ non-coplanar vertices")
    if triangles is not None:
        _warn_if_not_convex(where, scenario, shape.file, vertices, triangles)


# A mesh whose hull holds this much more than the mesh itself is not convex.
NOT_CONVEX = 1.05


def _warn_if_not_convex(
    where: str, scenario: sc.Scenario, file: str, vertices, triangles
) -> None:
    """A `!Convex` file that is not convex flies its hull, filling its
    notches: a ScenarioWarning, one line, says so and how to fly it."""
    if _behind_every_face(vertices, triangles):  # convex: no hull to compute
        return
    volume = enclosed_volume(vertices, triangles)
    hull = enclosed_volume(*shape_mesh(scenario, sc.Convex(vertices=vertices.tolist())))
    if volume > 0.0 and hull > NOT_CONVEX * volume:
        warnings.warn(
            f"{where}: shape.file = {file!r}: not convex (its hull holds "
            f"{hull / volume:.2f} times its volume), so !Convex flies the hull; "
            f"!Mesh {{file: {file}}} flies its shape",
            ScenarioWarning,
            stacklevel=2,
        )


def _behind_every_face(vertices: np.ndarray, triangles: np.ndarray) -> bool:
    """Whether no vertex lies in front of any face's plane (beyond a
    billionth of the mesh's size): a closed mesh so is convex. A cheap
    test that spares the convex shipped meshes computing a hull."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1)
    keep = lengths > 0.0  # degenerate faces have no plane
    normals = normals[keep] / lengths[keep, None]
    heights = vertices @ normals.T - np.einsum("ij,ij->i", normals, a[keep])
    return bool(heights.max(initial=0.0) <= 1e-9 * np.ptp(vertices))


def validate_scenario(scenario: sc.Scenario, where: str) -> None:
    """Raises ScenarioError for the first problem found, naming `where`."""
    sc.check_scenario(scenario, where)
    for i, obstacle in enumerate(scenario.obstacles):
        if isinstance(obstacle.shape, sc.Convex):
            _check_mesh(f"{where}: obstacles[{i}]", scenario, obstacle.shape)
    radius = as_vehicle(scenario.vehicle).collision_radius
    ends = [("start", scenario.start), ("goal", scenario.goal)]
    for i, other in enumerate(scenario.other_vehicles):
        ends += [
            (f"other_vehicles[{i}].{n}", getattr(other, n)) for n in ("start", "goal")
        ]
    if scenario.ground is not None:
        for name, point in ends:
            _check_above_ground(where, name, point, scenario.ground.height, radius)
    static = dataclasses.replace(
        scenario, obstacles=[o for o in scenario.obstacles if not moves(o.motion)]
    )
    try:
        # Starts against every obstacle at t = 0, goals against the static ones.
        closest = closest_obstacles(scenario, [p for n, p in ends if "start" in n])
        closest += closest_obstacles(static, [p for n, p in ends if "goal" in n])
    except RuntimeError as e:  # a mesh Drake cannot use
        raise sc.ScenarioError(f"{where}: obstacles: {str(e).splitlines()[0]}") from e
    ordered = [e for e in ends if "start" in e[0]] + [e for e in ends if "goal" in e[0]]
    for (name, point), (d, obstacle) in zip(ordered, closest, strict=True):
        needed, words = _room(name, radius, d)
        if d < needed - ROUNDING:
            sc.fail(where, name, point, _near(d, obstacle, words))
    if len(static.obstacles) < len(scenario.obstacles):
        for name, point in ends:
            if "goal" in name:
                _check_goal_uncovered(where, scenario, name, point, radius)
    _check_apart(where, scenario, radius)


def _near(distance: float, obstacle: sc.Obstacle | None, words: str) -> str:
    """Why an end at `distance` from `obstacle` is refused: inside or near
    it by its name, if it has one."""
    what = obstacle.name if obstacle is not None and obstacle.name else ""
    if what and distance < 0.0:
        return f"is inside {what} ({-distance:.3f} m deep)"
    return f"is {distance:.3f} m from {what or 'an obstacle'}, closer than {words}"


def _room(name: str, radius: float, distance: float) -> tuple[float, str]:
    """The least distance [m] an end `name` needs from any obstacle or the
    ground, and its words for an end at `distance`: a goal needs the
    GOAL_MARGIN beyond the radius."""
    words = f"the vehicle's collision radius {radius:.3f} m"
    if name.endswith("goal"):
        return radius + GOAL_MARGIN, (
            f"{words} plus the goal margin {GOAL_MARGIN:.3f} m (clearance "
            f"{distance - radius:.3f} m; docs/goals.md)"
        )
    return radius, words


def _check_goal_uncovered(where, scenario, name, point, radius) -> None:
    """A goal that moving obstacles cover for the whole flight is refused;
    one they cover at t = 0 only gives a ScenarioWarning."""
    moving = dataclasses.replace(
        scenario,
        obstacles=[o for o in scenario.obstacles if moves(o.motion)],
        ground=None,
    )
    times = np.linspace(0.0, scenario.duration, GOAL_SAMPLES)
    d = np.array(obstacle_distances(moving, [point] * len(times), times=times))
    if (d < radius).all():
        sc.fail(
            where,
            name,
            point,
            f"is within the collision radius {radius:.3f} m of a moving "
            f"obstacle throughout the flight",
        )
    if d[0] < radius:
        warnings.warn(
            f"{where}: {name} = {point!r}: a moving obstacle covers it at t = 0 "
            f"({d[0]:.3f} m away) and moves off by t = {times[d >= radius][0]:.2f} s",
            ScenarioWarning,
            stacklevel=2,
        )


def _check_above_ground(where, name, point, height, radius) -> None:
    above = point[2] - height
    needed, words = _room(name, radius, above)
    if above < needed - ROUNDING:
        sc.fail(
            where,
            name,
            point,
            f"is {above:.3f} m above the ground at z = {height:g} m, less than {words}",
        )


def _check_apart(where: str, scenario: sc.Scenario, radius: float) -> None:
    """No two vehicles start, or end, within their two collision radii of
    each other (a goal shared by two vehicles is one they cannot both hold)."""
    vehicles = [("the scenario's vehicle", "", scenario.start, scenario.goal)]
    for i, other in enumerate(scenario.other_vehicles):
        name = f"other_vehicles[{i}]"
        vehicles.append((name, f"{name}.", other.start, other.goal))
    for kind, index in (("start", 2), ("goal", 3)):
        for j, later in enumerate(vehicles):
            for earlier in vehicles[:j]:
                gap = float(np.linalg.norm(np.subtract(later[index], earlier[index])))
                if gap < 2.0 * radius:
                    sc.fail(
                        where,
                        f"{later[1]}{kind}",
                        later[index],
                        f"is {gap:.3f} m from the {kind} of {earlier[0]}, closer "
                        f"than their two collision radii {2.0 * radius:.3f} m",
                    )


def load_scenario(path: str, overrides: list[tuple[str, str]] = ()) -> sc.Scenario:
    """Loads scenario file `path`, layers `overrides` on it ((where, YAML
    text) pairs, see `config.scenario_yaml.parse_scenario`) and validates the
    result, its `world:` file and `!Mesh` shapes resolved into obstacles
    (`world_files.with_files`); raises ScenarioError if it cannot be flown."""
    where = layered_name(path, overrides)
    scenario = with_files(parse_scenario(path, overrides), where)
    validate_scenario(scenario, where)
    return scenario
