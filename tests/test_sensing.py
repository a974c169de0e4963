"""The sphere sensor against analytic closest points, shape by shape."""

import numpy as np
import pytest
from pydrake.geometry import SceneGraph

from mfi_drake.config import scenario as sc
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import OBSTACLE_COUNT, OBSTACLE_SIGNAL_SIZE
from mfi_drake.world.meshes import prism, write_obj
from mfi_drake.world.obstacles import (
    nearest_obstacles,
    obstacle_distances,
    obstacle_pose,
    register_obstacles,
)

_ALIVE = []  # a QueryObject reads its SceneGraph context: keep both alive


def query_for(obstacles, base_dir=""):
    scenario = sc.Scenario(obstacles=obstacles, base_dir=base_dir)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    context = scene_graph.CreateDefaultContext()
    _ALIVE.append((scene_graph, context))
    return scene_graph.get_query_output_port().Eval(context)


def box_closest(p_W, obstacle, half):
    """Clamp in the box frame: the exact closest point of a box from outside."""
    X = obstacle_pose(obstacle)
    p_B = X.inverse().multiply(p_W)
    return X.multiply(np.clip(p_B, -half, half))


ROTATED = [10.0, -20.0, 30.0]


@pytest.mark.parametrize(
    "p",
    [[3.0, 0.2, 0.1], [0.2, -3.5, 1.0], [-2.0, 2.5, 4.0], [0.1, 0.1, -4.0]],
)
def test_box_at_an_angle(p):
    obstacle = sc.Obstacle(sc.Box([2.0, 3.0, 4.0]), [0.5, -0.5, 0.0], ROTATED)
    signal = nearest_obstacles(query_for([obstacle]), np.array(p), 10.0)
    expected = box_closest(np.array(p), obstacle, np.array([1.0, 1.5, 2.0])) - p
    assert signal[3] == 1.0
    np.testing.assert_allclose(signal[:3], expected, atol=1e-9)


def test_sphere_capsule_cylinder_ellipsoid():
    c = np.array([1.0, 2.0, 3.0])
    p = c + [2.0, 1.0, -0.5]
    sphere = sc.Obstacle(sc.Sphere(0.7), list(c))
    d = p - c
    expected = -d * (1 - 0.7 / np.linalg.norm(d))
    np.testing.assert_allclose(
        nearest_obstacles(query_for([sphere]), p, 5)[:3], expected
    )

    # Capsule along z: distance to the segment minus the radius.
    capsule = sc.Obstacle(sc.Capsule(0.4, 2.0), list(c))
    for q in [c + [1.5, 0.5, 0.3], c + [0.3, -0.2, 3.0]]:
        nearest_axis = c + [0, 0, np.clip(q[2] - c[2], -1.0, 1.0)]
        d = q - nearest_axis
        expected = -d * (1 - 0.4 / np.linalg.norm(d))
        got = nearest_obstacles(query_for([capsule]), q, 5)[:3]
        np.testing.assert_allclose(got, expected, atol=1e-9)

    # Cylinder along z: radial from the side, straight down from above.
    cylinder = sc.Obstacle(sc.Cylinder(0.5, 2.0), list(c))
    side = c + [2.0, 0.0, 0.5]
    np.testing.assert_allclose(
        nearest_obstacles(query_for([cylinder]), side, 5)[:3], [-1.5, 0, 0], atol=1e-9
    )
    above = c + [0.2, 0.1, 2.5]
    np.testing.assert_allclose(
        nearest_obstacles(query_for([cylinder]), above, 5)[:3], [0, 0, -1.5], atol=1e-9
    )

    # Ellipsoid, from along a principal axis. Drake's point distance to an
    # ellipsoid is iterative: it lands within ~2 mm here.
    ellipsoid = sc.Obstacle(sc.Ellipsoid([1.0, 2.0, 3.0]), list(c))
    np.testing.assert_allclose(
        nearest_obstacles(query_for([ellipsoid]), c + [0, 3.5, 0], 5)[:3],
        [0, -1.5, 0],
        atol=5e-3,
    )


def test_convex_mesh_is_its_polytope(tmp_path):
    square = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    write_obj(str(tmp_path / "cube.obj"), *prism(square, 2.0))
    obstacle = sc.Obstacle(sc.Convex("cube.obj", 0.5), [4.0, 0.0, 1.0], ROTATED)
    query = query_for([obstacle], base_dir=str(tmp_path))
    for p in [np.array([2.0, 0.3, 1.2]), np.array([4.2, 2.0, -0.5])]:
        expected = box_closest(p, obstacle, np.full(3, 0.5)) - p
        np.testing.assert_allclose(
            nearest_obstacles(query, p, 5)[:3], expected, atol=1e-6
        )


def test_range_limit_and_the_nearest_of_several_nearest_first():
    near = sc.Obstacle(sc.Sphere(0.5), [2.0, 0, 0])
    far = sc.Obstacle(sc.Sphere(0.5), [0, 3.0, 0])
    query = query_for([far, near])
    signal = nearest_obstacles(query, np.zeros(3), 3.0)
    expected = np.zeros(OBSTACLE_SIGNAL_SIZE)
    expected[:8] = [1.5, 0, 0, 1.0, 0, 2.5, 0, 1.0]
    np.testing.assert_allclose(signal, expected, atol=1e-12)
    expected[4:] = 0.0  # the far one is out of range
    np.testing.assert_allclose(nearest_obstacles(query, np.zeros(3), 2.0), expected)
    np.testing.assert_array_equal(
        nearest_obstacles(query, np.zeros(3), 1.0), np.zeros(OBSTACLE_SIGNAL_SIZE)
    )


def test_only_the_nearest_obstacles_are_reported():
    """Spheres at distances 1.5, 2.5, ... along x: the reading holds the
    OBSTACLE_COUNT nearest, in order, whatever the registration order."""
    spheres = [sc.Obstacle(sc.Sphere(0.5), [2.0 + k, 0, 0]) for k in range(6)]
    signal = nearest_obstacles(query_for(spheres[::-1]), np.zeros(3), 100.0)
    readings = signal.reshape(OBSTACLE_COUNT, 4)
    np.testing.assert_allclose(readings[:, 0], 1.5 + np.arange(OBSTACLE_COUNT))
    np.testing.assert_array_equal(readings[:, 3], 1.0)


def test_the_vehicle_never_sees_itself():
    scenario = sc.Scenario(
        goal=[5.0, 0.0, 1.5], obstacles=[sc.Obstacle(sc.Sphere(0.5), [9.0, 9.0, 9.0])]
    )
    flight = build_diagram(scenario)
    context = flight.diagram.CreateDefaultContext()
    x0 = np.zeros(12)
    x0[:3] = scenario.start
    flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(x0)
    sensor = flight.diagram.GetSubsystemByName("sensor")
    signal = sensor.GetOutputPort("obstacle").Eval(sensor.GetMyContextFromRoot(context))
    np.testing.assert_array_equal(signal, np.zeros(OBSTACLE_SIGNAL_SIZE))


@pytest.mark.parametrize("y", [1.0, 9.0])
def test_flight_clearance_with_a_reach_equals_the_query_against_every_obstacle(y):
    """flight_metrics queries within CLEARANCE_REACH (and everything only if
    nothing was near); the oracle queries every obstacle at every step. A
    sphere beside the line (y = 1) and one far from the whole flight (y = 9)."""
    scenario = sc.Scenario(
        goal=[5.0, 0.0, 1.5],
        obstacles=[
            sc.Obstacle(sc.Sphere(0.5), [5.0, y, 2.0]),
            sc.Obstacle(sc.Box([1.0, 1.0, 1.0]), [5.0, -y - 3.0, 2.0]),
        ],
        duration=8.0,
    )
    flight = simulate(scenario)
    exact = min(obstacle_distances(scenario, flight.positions))
    assert flight.metrics["min_clearance"] == pytest.approx(
        exact - flight.collision_radius, abs=1e-12
    )
