"""The depth camera (paper §VI-B): its closest point against SceneGraph's
exact distance, what it cannot see, that it moves with the body, that it
renders at its own rate, bad camera fields, the yaw-follows-motion option and
the Pelican flights of Fig 11."""

import json
import math
import os

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import (
    Box,
    Cylinder,
    DepthCamera,
    Obstacle,
    Scenario,
    ScenarioError,
    Sphere,
)
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE
from mfi_drake.maths.quadcopter import desired_yaw
from mfi_drake.systems.camera import closest_return, pixel_rays
from mfi_drake.world.obstacles import nearest_obstacles
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

HEIGHT = 1.5  # m, the vehicle's altitude in the static views


def pixel_angle(camera: DepthCamera) -> float:
    """The angle one pixel subtends [rad] (square pixels, small angles)."""
    return math.radians(camera.fov_y_deg) / camera.height


def view(obstacles, attitude=(0.0, 0.0, 0.0), camera=None):
    """Renders one frame with the vehicle at [0, 0, HEIGHT] and the given
    (roll, pitch, yaw); returns (camera [r_o, seen], exact [r_o, seen])."""
    scenario = Scenario(
        name="view",
        vehicle="pelican",
        sensor=camera or DepthCamera(),
        obstacles=[Obstacle(shape=s, position=list(p)) for s, p in obstacles],
    )
    flight = build_diagram(scenario)
    context = flight.diagram.CreateDefaultContext()
    x = np.zeros(12)
    x[2] = HEIGHT
    x[3:6] = attitude
    flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(x)
    sensor = flight.diagram.GetSubsystemByName("sensor")
    held = sensor.sense(sensor.GetMyContextFromRoot(context))
    seen = np.append(held[:3] - x[:3], held[3]) if held[3] else held
    query = flight.scene_graph.get_query_output_port().Eval(
        flight.scene_graph.GetMyContextFromRoot(context)
    )
    return seen, nearest_obstacles(query, x[:3], np.inf)


# Each shape in view, the last two with the camera off the vehicle centre and
# tilted, so the back-projection and the camera pose on the body both count.
IN_VIEW = [
    pytest.param(
        Sphere(radius=0.5), [3.0, 0.4, HEIGHT + 0.3], DepthCamera(), id="sphere"
    ),
    pytest.param(
        Box(size=[0.6, 2.0, 1.0]),
        [2.5, -0.3, HEIGHT - 0.2],
        DepthCamera(position=[0.15, 0.0, -0.05], rpy_deg=[0.0, 10.0, 0.0]),
        id="box",
    ),
    pytest.param(
        Cylinder(radius=0.4, length=3.0),
        [2.0, 1.2, HEIGHT],
        DepthCamera(position=[0.1, 0.05, 0.0], rpy_deg=[0.0, 0.0, 25.0]),
        id="cylinder",
    ),
]


@pytest.mark.parametrize("shape,position,camera", IN_VIEW)
def test_closest_point_matches_scene_graph_exact_distance(shape, position, camera):
    seen, exact = view([(shape, position)], camera=camera)
    assert seen[3] == 1.0 and exact[3] == 1.0
    d = np.linalg.norm(exact[:3])
    # Each pixel samples the surface along its own ray, so every returned
    # point lies on the surface: the camera's distance is never below the
    # exact one, and the pixel ray nearest the exact closest point misses it
    # by at most half a pixel diagonal (0.71 pixel) at distance ~d. One pixel
    # footprint d·Δθ bounds both the point's error and the distance's, with
    # room for VTK's tessellation of the sphere and cylinder (~1 mm here).
    footprint = d * pixel_angle(camera)
    assert np.linalg.norm(seen[:3]) == pytest.approx(d, abs=footprint)
    assert np.linalg.norm(seen[:3]) >= d - 2e-3
    np.testing.assert_allclose(seen[:3], exact[:3], atol=footprint)


def test_nothing_in_view_when_the_obstacle_is_behind():
    seen, exact = view([(Sphere(radius=0.5), [-3.0, 0.0, HEIGHT])])
    assert np.linalg.norm(exact[:3]) == pytest.approx(2.5)  # within max_range
    np.testing.assert_array_equal(seen, np.zeros(4))


def test_nothing_in_view_beyond_max_range():
    seen, _ = view(
        [(Sphere(radius=0.5), [3.0, 0.0, HEIGHT])], camera=DepthCamera(max_range=2.0)
    )
    np.testing.assert_array_equal(seen, np.zeros(4))


def test_the_camera_moves_with_the_body():
    # A ahead (+x), B to the right (−y), C ahead and 45° below.
    obstacles = [
        (Sphere(radius=0.5), [3.0, 0.0, HEIGHT]),
        (Sphere(radius=0.5), [0.0, -3.0, HEIGHT]),
        (Sphere(radius=0.5), [2.0, 0.0, HEIGHT - 2.0]),
    ]
    tolerance = 3.0 * pixel_angle(DepthCamera())  # a pixel footprint at ≤ 3 m
    cases = [
        ((0.0, 0.0, 0.0), [2.5, 0.0, 0.0]),  # level: A
        ((0.0, 0.0, -math.pi / 2), [0.0, -2.5, 0.0]),  # yawed right: B
        ((0.0, math.pi / 4, 0.0), None),  # pitched 45° nose down: C
        ((0.3, 0.0, 0.0), [2.5, 0.0, 0.0]),  # rolled: still A
    ]
    for attitude, expected in cases:
        seen, _ = view(obstacles, attitude)
        assert seen[3] == 1.0, attitude
        if expected is None:  # C's closest point to the vehicle centre
            c = np.array([2.0, 0.0, -2.0])
            expected = c - 0.5 * c / np.linalg.norm(c)
        np.testing.assert_allclose(seen[:3], expected, atol=tolerance)
    seen, _ = view(obstacles, (0.0, 0.0, math.pi))  # facing −x: nothing
    assert seen[3] == 0.0


def test_back_projection_of_a_flat_wall_by_hand():
    # A 3x3 image of a wall at depth 2 (one pixel with no return, one too
    # close), a camera at [1, 0, 0] looking along world +x (C's z).
    rays = pixel_rays(3, 3, 2.0, 2.0, 1.0, 1.0)
    depth = np.full((3, 3), 2.0)
    depth[1, 1] = np.inf
    R_WC = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    p_WC = np.array([1.0, 0.0, 0.0])
    # Pixel (u=2, v=1) is 1/2 to the right at depth 2: C point [1, 0, 2],
    # world [3, −1, 0]; seen from p = [3, −3, 0] it is the closest.
    out = closest_return(depth, rays, R_WC, p_WC, np.array([3.0, -3.0, 0.0]))
    np.testing.assert_allclose(out, [3.0, -1.0, 0.0, 1.0])
    depth[0, 0] = 0.0  # closer than MIN_DEPTH: a return at MIN_DEPTH, not none
    out = closest_return(depth, rays, R_WC, p_WC, p_WC)
    assert out[3] == 1.0 and np.linalg.norm(out[:3] - p_WC) < 0.05
    empty = closest_return(np.full((3, 3), np.inf), rays, R_WC, p_WC, p_WC)
    np.testing.assert_array_equal(empty, np.zeros(4))


def test_renders_at_its_own_rate_and_holds_the_point_between_frames():
    scenario = load_scenario(os.path.join(SCENARIOS, "pelican_cylinder.yaml"))
    scenario.duration = 2.51
    flight = simulate(scenario)
    rate = scenario.sensor.rate_hz
    # Frames at k/rate for k = 0 … 75 (75/30 = 2.5 < 2.51).
    assert flight.frames_rendered == 76
    assert flight.metrics["frames_rendered"] == 76
    assert flight.metrics["sensor"] == "depth"
    assert flight.metrics["steps"] > flight.frames_rendered
    obstacle, p = flight.log["obstacle"], flight.positions
    # The sample at t = 0 is logged before the first frame; a sample at a
    # frame time k/rate closes the step before that frame's update.
    np.testing.assert_array_equal(obstacle[0], np.zeros(OBSTACLE_SIGNAL_SIZE))
    assert np.all(obstacle[1:, 3] == 1.0)  # the cylinder is in view all along
    held = obstacle[:, :3] + p  # the world point the camera last saw
    frame = np.ceil(flight.times * rate - 1e-6)
    same = frame[1:] == frame[:-1]
    assert same.sum() > 100  # plenty of steps between frames
    np.testing.assert_allclose(held[1:][same], held[:-1][same], atol=1e-9)
    assert np.max(np.linalg.norm(np.diff(held, axis=0), axis=1)) > 1e-3


@pytest.mark.parametrize("name", ["pelican_cylinder", "pelican_cube"])
def test_pelican_fig11_flight_succeeds_with_the_depth_camera(name, tmp_path, capsys):
    path = os.path.join(SCENARIOS, f"{name}.yaml")
    assert isinstance(load_scenario(path).sensor, DepthCamera)
    assert main(["run", path, "--json", "--out", str(tmp_path)]) == 0
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["sensor"] == "depth" and metrics["vehicle"] == "pelican"
    assert metrics["success"] and metrics["min_clearance"] > 0.0
    assert metrics["frames_rendered"] == round(metrics["sim_time"] * 30.0)


def test_yaw_following_motion_lets_the_camera_see_a_side_obstacle():
    scenario = load_scenario(os.path.join(SCENARIOS, "pelican_side_goal.yaml"))
    assert scenario.navigator.yaw_follows_motion
    following = simulate(scenario)
    scenario.navigator.yaw_follows_motion = False
    scenario.duration = 6.0  # it has hit the cylinder by then
    fixed = simulate(scenario)
    assert following.metrics["success"] and following.metrics["min_clearance"] > 0
    assert fixed.metrics["collided"]  # looking along +x it never sees it in time
    first_seen = [
        f.times[np.argmax(f.log["obstacle"][:, 3] > 0.5)] for f in (following, fixed)
    ]
    assert first_seen[0] < 1.0 < 3.0 < first_seen[1]


def test_desired_yaw():
    params = NavigatorParams()
    v = np.array([-1.0, 1.0, 0.3])
    assert desired_yaw(v, 0.4, params) == 0.0  # the paper's θ_y,d = 0
    params.yaw_follows_motion = True
    # Fast: the heading (the setpoint may differ from it by whole turns).
    yaw = desired_yaw(v, 0.4, params)
    assert math.remainder(yaw - 3 * math.pi / 4, 2 * math.pi) == pytest.approx(0.0)
    assert desired_yaw(v, -3.0, params) == pytest.approx(3 * math.pi / 4 - 2 * math.pi)
    # Slower than v_stop: hold the current yaw; halfway to v_min: halfway.
    assert desired_yaw(0.5 * params.v_stop * v / 1.5, 0.4, params) == 0.4
    half = (params.v_stop + params.v_min) / 2
    slow = half * np.array([0.0, 1.0, 0.0])
    assert desired_yaw(slow, 0.4, params) == pytest.approx(
        0.4 + (math.pi / 2 - 0.4) / 2
    )


CAMERA = """\
name: camera
start: [0.0, 0.0, 1.0]
goal: [6.0, 0.0, 1.0]
vehicle: pelican
sensor: !DepthCamera {FIELDS}
"""


@pytest.mark.parametrize(
    "fields,name",
    [
        ("{width: 0}", "sensor.width"),
        ("{height: -120}", "sensor.height"),
        ("{width: 160.5}", "sensor.width"),
        ("{fov_y_deg: 180.0}", "sensor.fov_y_deg"),
        ("{fov_y_deg: 0.0}", "sensor.fov_y_deg"),
        ("{max_range: 0.0}", "sensor.max_range"),
        ("{max_range: .inf}", "sensor.max_range"),
        ("{rate_hz: -30.0}", "sensor.rate_hz"),
        ("{position: [0.1, 0.0]}", "sensor.position"),
        ("{rpy_deg: [0.0, .nan, 0.0]}", "sensor.rpy_deg"),
    ],
)
def test_bad_camera_fields_are_rejected_naming_the_field(write_yaml, fields, name):
    path = write_yaml(CAMERA.replace("{FIELDS}", fields))
    with pytest.raises(ScenarioError) as error:
        load_scenario(path)
    message = str(error.value)
    assert f"{name} = " in message and "\n" not in message
