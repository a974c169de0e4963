"""How many readings a sensor reports (`sensor.readings`): validated, the
ports and the escape memory sized by it, and a slab whose floor and ceiling
take two of three readings read with a fourth."""

import numpy as np
import pytest
from pydrake.geometry import SceneGraph

from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.config import sensors
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.step import NavigationStep
from mfi_drake.maths import escape
from mfi_drake.maths.layout import OBSTACLE_COUNT, obstacle_signal, point_readings
from mfi_drake.systems.camera import DepthCameraSensor, mounted_cameras
from mfi_drake.systems.exchange import OtherVehicleReadings
from mfi_drake.systems.point_map import PointMapSensor
from mfi_drake.world.obstacles import nearest_obstacles, register_obstacles

from .test_scenario import GOOD

_ALIVE = []  # a QueryObject reads its SceneGraph context: keep both alive


@pytest.mark.parametrize("value", ["0", "-2", "2.5", "many", "true"])
def test_a_count_below_one_or_not_an_integer_is_one_line_and_exit_2(
    write_yaml, tmp_path, capsys, value
):
    text = GOOD.replace("{radius: 2.5}", f"{{radius: 2.5, readings: {value}}}")
    assert main(["run", write_yaml(text), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert "readings" in err and value in err.lower()


def test_every_port_and_the_escape_memory_follow_the_count():
    """A scenario of 5 readings: the sensor's output, the navigator's input,
    the log's "obstacle" columns are 20 long, the escape memory holds 5
    rows of each per-reading record; the other sensor kinds and the fleet's
    readings declare 5 readings too."""
    scenario = sc.Scenario(
        goal=[4.0, 0.0, 1.0],
        start=[0.0, 0.0, 1.0],
        sensor=sc.SphereSensor(readings=5),
        obstacles=[sc.Obstacle(sc.Sphere(0.5), [2.0, 0.0, 1.0])],
    )
    flight = build_diagram(scenario, "mfi")
    assert flight.sensor.GetOutputPort("obstacle").size() == 20
    navigator = flight.handles.navigator
    assert navigator.GetInputPort("obstacle").size() == 20
    memory = navigator.CreateDefaultContext().get_discrete_state_vector().size()
    assert memory == escape.MEMORY_SIZE + escape.PER_READING * (5 - OBSTACLE_COUNT)
    columns = flight.log_slices()["obstacle"]
    assert columns.stop - columns.start == 20
    camera = sensors.DepthCamera(readings=5)
    depth = DepthCameraSensor(mounted_cameras(camera), 30.0, 6.0, readings=5)
    point_map = PointMapSensor(np.zeros((1, 3)), 3.0, readings=5)
    fleet = OtherVehicleReadings(2, 0.225, 3.0, readings=5)
    for system in (depth, point_map, fleet):
        assert system.GetOutputPort("obstacle").size() == 20
    assert fleet.GetOutputPort("scene").size() == 20
    assert fleet.GetOutputPort("obstacle_velocity").size() == 15
    assert fleet.GetOutputPort("vehicle_readings").size() == 5


def test_a_larger_memory_evolves_as_the_default_one_on_as_many_readings():
    """The count only resizes the escape memory: fed the same two readings,
    a memory of 6 readings keeps every record a memory of 3 keeps, its
    extra rows untouched (inf: no point, a plane's radius)."""
    p, goal = np.array([0.0, 0.0, 1.0]), np.array([5.0, 0.0, 1.0])
    small = escape.initial_memory(p, goal)
    large = escape.initial_memory(p, goal, 6)
    assert len(large) == escape.memory_size(6) == escape.FIXED_SIZE + 42
    wall = [np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.6, 0.0])]
    rule = escape.EscapeParams()
    for k in range(40):
        t, x = 0.5 * k, p + [0.01 * k, 0.0, 0.0]
        v = np.array([0.02, 0.0, 0.0])
        small = escape.update_memory(
            small, t, x, v, obstacle_signal(wall), goal, 0.225, rule, None
        )
        large = escape.update_memory(
            large, t, x, v, obstacle_signal(wall, 6), goal, 0.225, rule, None
        )
    fixed = slice(0, escape.FIXED_SIZE)
    np.testing.assert_array_equal(large[fixed], small[fixed])
    assert small[escape.PHASE] != escape.TOWARD  # the rule did act
    for name, rows in (("_last_points", 3), ("_seen_points", 3), ("_radii", 1)):
        big, few = getattr(escape, name)(large), getattr(escape, name)(small)
        np.testing.assert_array_equal(big[:3], few)
        np.testing.assert_array_equal(big[3:], np.full((3, rows), np.inf).squeeze())


# A 1 m slab as BARN's (benchmarks/barn.py): the floor's top 0.45 m below
# the vehicle at the origin, the ceiling 0.55 m above, a cylinder 0.4 m
# beside (+y) and one 0.8 m ahead (+x), both of radius 0.075 m.
SLAB = [
    sc.Obstacle(sc.Box([20.0, 20.0, 1.0]), [0.0, 0.0, -0.95]),
    sc.Obstacle(sc.Box([20.0, 20.0, 1.0]), [0.0, 0.0, 1.05]),
    sc.Obstacle(sc.Cylinder(0.075, 1.0), [0.875, 0.0, 0.05]),
    sc.Obstacle(sc.Cylinder(0.075, 1.0), [0.0, 0.475, 0.05]),
]
BESIDE, FLOOR, CEILING, AHEAD = [0, 0.4, 0], [0, 0, -0.45], [0, 0, 0.55], [0.8, 0, 0]


def test_in_a_slab_three_readings_hide_the_cylinder_ahead_and_four_read_it():
    scenario = sc.Scenario(obstacles=SLAB)
    scene_graph = SceneGraph()
    register_obstacles(scene_graph, scenario)
    context = scene_graph.CreateDefaultContext()
    _ALIVE.append((scene_graph, context))
    query = scene_graph.get_query_output_port().Eval(context)
    p = np.zeros(3)
    three = nearest_obstacles(query, p, 3.0)
    np.testing.assert_allclose(
        three, obstacle_signal([BESIDE, FLOOR, CEILING]), atol=1e-9
    )
    four = nearest_obstacles(query, p, 3.0, count=4)
    expected = obstacle_signal([BESIDE, FLOOR, CEILING, AHEAD], 4)
    np.testing.assert_allclose(four, expected, atol=1e-9)
    # A second reader: the closest points themselves, as NavigationStep reads.
    points = np.array([BESIDE, AHEAD, FLOOR, CEILING], float)
    np.testing.assert_allclose(point_readings(p, points, 3.0, 4), expected, atol=0)
    step = NavigationStep([5.0, 0.0, 0.0], "mfi-memoryless", readings=4)
    state = np.zeros(12)
    np.testing.assert_allclose(step.step(state, points).obstacle, expected, atol=0)
