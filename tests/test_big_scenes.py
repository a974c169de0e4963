"""Big scenes: a ground under a thousand obstacles does not crash SceneGraph
(the ground was a HalfSpace, whose infinite bounding box corrupted FCL's
broadphase tree: a segmentation fault while loading, Drake issue #19263),
and the ground box that replaces it measures as the half space would."""

import subprocess
import sys
import textwrap

import numpy as np
from pydrake.geometry import SceneGraph

from mfi_drake.config import scenario as sc
from mfi_drake.world.generator import random_obstacle
from mfi_drake.world.obstacles import (
    closest_obstacles,
    obstacle_distances,
    register_obstacles,
)

from .conftest import ROOT

# A thousand cubes over 40 × 30 × 3 m and a ground: with the ground a
# HalfSpace, every run of this crashed (exit 139) on Drake 1.51, and 7 in 10
# `mfi-drake run`s of a 150-cube scene did.
CROWD = textwrap.dedent(
    """
    import numpy as np
    from pydrake.geometry import SceneGraph
    from mfi_drake.config import scenario as sc
    from mfi_drake.world.obstacles import register_obstacles
    rng = np.random.default_rng({seed})
    cubes = [
        sc.Obstacle(shape=sc.Box(size=[0.3, 0.3, 0.3]), position=p.tolist())
        for p in rng.uniform([0, 0, 0], [40, 30, 3], (1000, 3))
    ]
    scenario = sc.Scenario(obstacles=cubes, ground=sc.Ground(height=0.0))
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    for _ in range(3):  # each context copies the broadphase tree
        context = scene_graph.CreateDefaultContext()
        query = scene_graph.get_query_output_port().Eval(context)
        query.ComputeSignedDistanceToPoint([20.0, 15.0, 1.5], 1e9)
    """
)


def test_a_thousand_obstacles_and_a_ground_load_without_crashing():
    for seed in range(2):
        run = subprocess.run(
            [sys.executable, "-c", CROWD.format(seed=seed)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert run.returncode == 0, (seed, run.returncode, run.stderr[-500:])


def test_the_ground_box_measures_as_the_plane():
    """Closest points on the ground, against the plane's closed form
    (distance z − h, the point below): at the origin and 5 km out."""
    ground = sc.Ground(height=-0.7)
    scenario = sc.Scenario(obstacles=[], ground=ground)
    rng = np.random.default_rng(3)
    points = np.vstack(
        [
            rng.uniform([-20, -20, -0.5], [20, 20, 30], (50, 3)),
            rng.uniform([-5e3, -5e3, 0.0], [5e3, 5e3, 10.0], (50, 3)),
        ]
    )
    found = obstacle_distances(scenario, points)
    np.testing.assert_allclose(found, points[:, 2] - ground.height, atol=1e-12)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    for p in points:
        (r,) = query.ComputeSignedDistanceToPoint(p, 1e9)
        closest = p - r.distance * r.grad_W
        np.testing.assert_allclose(closest, [*p[:2], ground.height], atol=1e-12)


def test_asking_the_candidates_alone_gives_every_obstacles_answer():
    """`closest_obstacles` (which registers only the obstacles that can be
    nearest) against SceneGraph asked about every obstacle: 300 random
    obstacles of every kind, rotated, over a ground, and points among and
    beyond them; the same distance and the same obstacle (or the ground)
    for each point."""
    rng = np.random.default_rng(5)
    low, high = np.array([0.0, 0.0, 0.0]), np.array([30.0, 20.0, 4.0])
    obstacles = [random_obstacle(rng, low, high) for _ in range(300)]
    scenario = sc.Scenario(obstacles=obstacles, ground=sc.Ground(height=-0.3))
    points = rng.uniform(low - 3.0, high + 3.0, (200, 3))
    got = closest_obstacles(scenario, points)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    inspector = query.inspector()
    for p, (distance, obstacle) in zip(points, got, strict=True):
        nearest = min(
            query.ComputeSignedDistanceToPoint(p, 1e9), key=lambda r: r.distance
        )
        assert distance == nearest.distance
        name = inspector.GetName(nearest.id_G)
        expected = None if name == "ground" else obstacles[int(name.split("_")[1])]
        assert obstacle is expected
