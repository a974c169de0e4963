"""Loading a scenario that can be flown: `config.scenario`'s checks plus the
geometric ones (readable convex meshes; start and goal in free space with
room for the vehicle)."""

import os

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.world.meshes import read_obj_vertices
from mfi_drake.world.obstacles import obstacle_distances


def _check_mesh(where: str, scenario: sc.Scenario, shape: sc.Convex) -> None:
    path = sc.mesh_path(scenario, shape)
    if not shape.file or not os.path.isfile(path):
        sc.fail(where, "shape.file", shape.file, f"no such file ({path})")
    try:
        vertices = read_obj_vertices(path)
    except ValueError as e:
        sc.fail(where, "shape.file", shape.file, str(e))
    centred = vertices - vertices.mean(axis=0)
    if len(vertices) < 4 or np.linalg.matrix_rank(centred, tol=1e-9) < 3:
        sc.fail(where, "shape.file", shape.file, "needs 4+ non-coplanar vertices")


def validate_scenario(scenario: sc.Scenario, where: str) -> None:
    """Raises ScenarioError for the first problem found, naming `where`."""
    sc.check_scenario(scenario, where)
    for i, obstacle in enumerate(scenario.obstacles):
        if isinstance(obstacle.shape, sc.Convex):
            _check_mesh(f"{where}: obstacles[{i}]", scenario, obstacle.shape)
    radius = VEHICLES[scenario.vehicle].collision_radius
    try:
        distances = obstacle_distances(scenario, [scenario.start, scenario.goal])
    except RuntimeError as e:  # a mesh Drake cannot use
        raise sc.ScenarioError(f"{where}: obstacles: {str(e).splitlines()[0]}") from e
    for name, point, d in zip(
        ("start", "goal"), (scenario.start, scenario.goal), distances, strict=True
    ):
        if d < radius:
            sc.fail(
                where,
                name,
                point,
                f"is {d:.3f} m from an obstacle, closer than the vehicle's "
                f"collision radius {radius:.3f} m",
            )


def load_scenario(path: str, overrides: list[tuple[str, str]] = ()) -> sc.Scenario:
    """Loads scenario file `path`, layers `overrides` on it ((where, YAML
    text) pairs, see `config.scenario.parse_scenario`) and validates the
    result; raises ScenarioError if it cannot be flown."""
    scenario = sc.parse_scenario(path, overrides)
    validate_scenario(scenario, path)
    return scenario
