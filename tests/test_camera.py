"""The depth cameras (paper §VI-B) in a diagram: readings against
SceneGraph's exact distances, several obstacles, the memory beyond the field
of view, free space, the state estimate, rigs, bad camera configurations,
the yaw-follows-motion option and the Pelican flights of Fig 11."""

import json
import math
import os

import numpy as np
import pytest
from pydrake.geometry import SceneGraph
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from mfi_drake.app.cli import main
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import Box, Cylinder, Obstacle, Scenario, Sphere
from mfi_drake.config.scenario_yaml import parse_scenario, read_override
from mfi_drake.config.sensors import DepthCamera, DepthCameraRig, Gimbal, RigCamera
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.gimbal import gimbal_rotation, point_gimbal
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, VELOCITY, seen_points
from mfi_drake.maths.quadcopter import desired_yaw
from mfi_drake.systems.camera import add_depth_cameras, mounted_cameras
from mfi_drake.systems.sensors import VehicleGeometry
from mfi_drake.world.obstacles import nearest_obstacles, register_obstacles
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

HEIGHT = 1.5  # m, the vehicle's altitude in the static views
FRAME = 1.0 / 30.0  # s between frames at the default rate


def pixel_angle(camera: DepthCamera) -> float:
    """The angle one pixel subtends [rad] (square pixels, small angles)."""
    return math.radians(camera.fov_y_deg) / camera.height


def state(
    position=(0.0, 0.0, HEIGHT), attitude=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0)
) -> np.ndarray:
    x = np.zeros(12)
    x[:3], x[3:6], x[VELOCITY] = position, attitude, velocity
    return x


class Rig:
    """The obstacles and a camera rig on a vehicle held at a given state:
    "state" (true, what is rendered) and "estimate" (what the perception
    places the images with) are inputs of the diagram."""

    def __init__(self, obstacles, sensor=None):
        self.scenario = Scenario(
            sensor=sensor or DepthCamera(),
            obstacles=[Obstacle(shape=s, position=list(p)) for s, p in obstacles],
        )
        builder = DiagramBuilder()
        self.scene_graph = builder.AddSystem(SceneGraph())
        register_obstacles(self.scene_graph, self.scenario)
        geometry = builder.AddSystem(VehicleGeometry(self.scene_graph, 0.21, 0.1))
        builder.Connect(
            geometry.get_output_port(0),
            self.scene_graph.get_source_pose_port(geometry.source_id),
        )
        self.sensor = add_depth_cameras(
            builder,
            self.scenario.sensor,
            self.scene_graph,
            geometry.frame_id,
            geometry.get_output_port(0),
        )
        builder.ExportInput(geometry.get_input_port(0), "state")
        builder.ExportInput(self.sensor.GetInputPort("state"), "estimate")
        self.diagram = builder.Build()
        self.simulator = Simulator(self.diagram)
        self.context = self.simulator.get_mutable_context()

    def at(self, t: float, x: np.ndarray, estimate: np.ndarray | None = None):
        """Holds the vehicle at x (estimated at `estimate`, default x) until
        time t; returns the readings r_o (k, 3) then."""
        self.diagram.GetInputPort("state").FixValue(self.context, x)
        self.diagram.GetInputPort("estimate").FixValue(
            self.context, x if estimate is None else estimate
        )
        self.simulator.AdvanceTo(t)
        port = self.sensor.GetOutputPort("obstacle")
        return seen_points(port.Eval(self.sensor.GetMyContextFromRoot(self.context)))

    def exact(self, p) -> np.ndarray:
        """SceneGraph's exact closest point of each obstacle to p (r_o,
        nearest first), as the sphere sensor reads them (after `at`)."""
        query = self.scene_graph.get_query_output_port().Eval(
            self.scene_graph.GetMyContextFromRoot(self.context)
        )
        return seen_points(nearest_obstacles(query, np.asarray(p, float), np.inf))

    def remove_obstacle(self, index: int) -> None:
        """Takes obstacle `index` out of the scene (what was remembered of it
        is then free space)."""
        inspector = self.scene_graph.model_inspector()
        (source,) = [
            s
            for s in inspector.GetAllSourceIds()
            if inspector.GetName(s) == "obstacles"
        ]
        (geometry,) = [
            g
            for g in inspector.GetAllGeometryIds()
            if inspector.GetName(g) == f"obstacle_{index}"
        ]
        self.scene_graph.RemoveGeometry(
            self.scene_graph.GetMyMutableContextFromRoot(self.context), source, geometry
        )


def first_frame(obstacles, attitude=(0.0, 0.0, 0.0), camera=None):
    """(readings, exact closest points) after the first frame, the vehicle
    at [0, 0, HEIGHT] with the given (roll, pitch, yaw)."""
    rig = Rig(obstacles, camera)
    x = state(attitude=attitude)
    return rig.at(0.5 * FRAME, x), rig.exact(x[:3])


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
    seen, exact = first_frame([(shape, position)], camera=camera)
    assert len(seen) == 1 and len(exact) == 1
    d = np.linalg.norm(exact[0])
    # Each pixel samples the surface along its own ray, so every returned
    # point lies on the surface: the camera's distance is never below the
    # exact one, and the pixel ray nearest the exact closest point misses it
    # by at most half a pixel diagonal (0.71 pixel) at distance ~d; thinning
    # keeps the nearest return of its block. One pixel footprint d·Δθ
    # bounds both the point's error and the distance's, with room for VTK's
    # tessellation of the sphere and cylinder (~1 mm here).
    footprint = d * pixel_angle(camera)
    assert np.linalg.norm(seen[0]) == pytest.approx(d, abs=footprint)
    assert np.linalg.norm(seen[0]) >= d - 2e-3
    np.testing.assert_allclose(seen[0], exact[0], atol=footprint)


def test_nothing_in_view_when_the_obstacle_is_behind():
    seen, exact = first_frame([(Sphere(radius=0.5), [-3.0, 0.0, HEIGHT])])
    assert np.linalg.norm(exact[0]) == pytest.approx(2.5)  # within max_range
    assert len(seen) == 0


def test_nothing_in_view_beyond_max_range():
    seen, _ = first_frame(
        [(Sphere(radius=0.5), [3.0, 0.0, HEIGHT])], camera=DepthCamera(max_range=2.0)
    )
    assert len(seen) == 0


def test_the_camera_moves_with_the_body():
    # A ahead (+x), B to the right (−y), C ahead and 45° below.
    obstacles = [
        (Sphere(radius=0.5), [3.0, 0.0, HEIGHT]),
        (Sphere(radius=0.5), [0.0, -3.0, HEIGHT]),
        (Sphere(radius=0.5), [2.0, 0.0, HEIGHT - 2.0]),
    ]
    tolerance = 3.0 * pixel_angle(DepthCamera())  # a pixel footprint at ≤ 3 m
    c = np.array([2.0, 0.0, -2.0])
    cases = [
        ((0.0, 0.0, 0.0), [2.5, 0.0, 0.0]),  # level: A
        ((0.0, 0.0, -math.pi / 2), [0.0, -2.5, 0.0]),  # yawed right: B
        ((0.0, math.pi / 4, 0.0), c - 0.5 * c / np.linalg.norm(c)),  # nose down: C
        ((0.3, 0.0, 0.0), [2.5, 0.0, 0.0]),  # rolled: still A
    ]
    for attitude, expected in cases:
        seen, _ = first_frame(obstacles, attitude)
        assert len(seen) == 1, attitude
        np.testing.assert_allclose(seen[0], expected, atol=tolerance)
    seen, _ = first_frame(obstacles, (0.0, 0.0, math.pi))  # facing −x: nothing
    assert len(seen) == 0


def test_two_separated_boxes_give_two_readings_and_one_box_one():
    left = (Box(size=[0.5, 0.8, 1.0]), [2.5, 0.9, HEIGHT])
    right = (Box(size=[0.5, 0.8, 1.0]), [3.2, -1.0, HEIGHT + 0.3])
    tolerance = 3.5 * pixel_angle(DepthCamera())
    seen, exact = first_frame([left, right])
    assert len(seen) == 2 and len(exact) == 2
    np.testing.assert_allclose(seen, exact, atol=tolerance)  # both, nearest first
    seen, exact = first_frame([right])
    assert len(seen) == 1
    np.testing.assert_allclose(seen, exact, atol=tolerance)


def test_a_wall_seen_edge_on_is_one_obstacle():
    # A 10 m wall 0.9 m to the left, running along the view out of range: its
    # samples are ever sparser with range (0.6 m apart at 4 m, one a 4×4
    # block), but it is one surface, read at its exact closest point (its
    # near end, in view).
    wall = (Box(size=[10.0, 0.1, 3.0]), [7.0, 0.95, HEIGHT])
    seen, exact = first_frame([wall])
    assert len(seen) == 1
    np.testing.assert_allclose(
        seen[0], exact[0], atol=np.linalg.norm(exact[0]) * pixel_angle(DepthCamera())
    )


def test_an_obstacle_out_of_view_is_remembered_for_memory_s_then_forgotten():
    memory = 1.0
    rig = Rig([(Sphere(radius=0.5), [2.0, 1.0, HEIGHT])], DepthCamera(memory_s=memory))
    ahead, away = state(), state(attitude=(0.0, 0.0, math.pi))
    seen = rig.at(0.5 * FRAME, ahead)
    exact = rig.exact(ahead[:3])
    tolerance = 2.0 * pixel_angle(DepthCamera())
    np.testing.assert_allclose(seen, exact, atol=tolerance)
    # Turned away from t = FRAME on, the last sighting is the frame at t = 0.
    for t in (1.5 * FRAME, 0.5, memory - 0.5 * FRAME):
        np.testing.assert_allclose(rig.at(t, away), exact, atol=tolerance)
    # The first frame at least memory_s after the sighting forgets it.
    assert len(rig.at(memory + 0.5 * FRAME, away)) == 0


def test_free_space_where_a_remembered_point_was_clears_it():
    rig = Rig([(Box(size=[0.4, 0.4, 0.4]), [2.0, 0.0, HEIGHT])])
    x = state()
    assert len(rig.at(0.5 * FRAME, x)) == 1
    rig.remove_obstacle(0)
    assert len(rig.exact(x[:3])) == 0
    # The next frame sees through where it was: cleared long before memory_s.
    assert len(rig.at(1.5 * FRAME, x)) == 0
    assert (
        len(
            rig.sensor.percept(
                rig.sensor.GetMyContextFromRoot(rig.context)
            ).memory.points
        )
        == 0
    )


def test_what_is_remembered_carries_the_state_estimates_error():
    rig = Rig([(Sphere(radius=0.5), [2.5, 0.0, HEIGHT])])
    x = state()
    seen = rig.at(0.5 * FRAME, x)
    # Turned away, the vehicle's estimate drifts 0.3 m toward the sphere
    # although it has not moved: the remembered point stays where it was
    # placed, so the reading is 0.3 m short (the sample nearest the estimate
    # on the sphere's axis is still the one read before).
    away = state(attitude=(0.0, 0.0, math.pi))
    drifted = away.copy()
    drifted[0] += 0.3
    np.testing.assert_allclose(
        rig.at(1.5 * FRAME, away, drifted), seen - [0.3, 0.0, 0.0], atol=1e-6
    )


def test_flights_place_the_memory_with_the_controllers_estimate():
    scenario = load_scenario(os.path.join(SCENARIOS, "pelican_cube.yaml"))
    scenario.faults.position_noise_std = 0.05
    flight = build_diagram(scenario)
    connections = flight.diagram.connection_map()
    sensor = flight.diagram.GetSubsystemByName("sensor")
    estimate = flight.diagram.GetSubsystemByName("state_estimate")
    source = connections[(sensor, sensor.GetInputPort("state").get_index())]
    assert source == (estimate, estimate.GetOutputPort("estimate").get_index())


def test_a_rig_of_two_cameras_sees_ahead_and_behind():
    back = RigCamera(max_range=4.0)
    back.X_BC.set_rotation_rpy_deg([-90.0, 0.0, 90.0])  # looking along body −x
    rig = DepthCameraRig(cameras=[RigCamera(), back])
    obstacles = [
        (Sphere(radius=0.5), [3.0, 0.0, HEIGHT]),
        (Sphere(radius=0.5), [-2.0, 0.5, HEIGHT]),
    ]
    seen, exact = first_frame(obstacles, camera=rig)
    assert len(seen) == 2
    np.testing.assert_allclose(seen, exact, atol=3.0 * pixel_angle(DepthCamera()))
    frames = Rig(obstacles, rig)
    frames.at(2.5 * FRAME, state())
    port = frames.sensor.GetOutputPort("frames_rendered")
    assert port.Eval(frames.sensor.GetMyContextFromRoot(frames.context))[0] == 6


def test_the_depth_camera_form_is_a_rig_of_one_camera(write_yaml):
    camera = DepthCamera(position=[0.1, 0.0, -0.05], rpy_deg=[5.0, 10.0, 20.0])
    (mounted,) = mounted_cameras(camera)
    # The same pose written as Drake writes one: X_BC = X_BL · R_LC.
    X_BL = RigidTransform(
        RollPitchYaw(np.radians([5.0, 10.0, 20.0])), [0.1, 0.0, -0.05]
    )
    R_LC = RollPitchYaw(np.radians([-90.0, 0.0, -90.0]))
    X_BC = X_BL @ RigidTransform(R_LC, np.zeros(3))
    np.testing.assert_allclose(
        mounted.X_MC.GetAsMatrix4(), X_BC.GetAsMatrix4(), atol=1e-12
    )
    # On a gimbal the same rpy poses it in the gimbal's frame, at the
    # gimbal's centre (`position` is the gimbal's).
    gimballed = DepthCamera(
        position=[0.1, 0.0, -0.05], rpy_deg=[5.0, 10.0, 20.0], gimbal=Gimbal()
    )
    (mounted,) = mounted_cameras(gimballed)
    np.testing.assert_allclose(
        mounted.X_MC.GetAsMatrix4(),
        RigidTransform(X_BC.rotation(), np.zeros(3)).GetAsMatrix4(),
        atol=1e-12,
    )
    path = write_yaml(
        """\
        name: rig
        goal: [5.0, 0.0, 1.5]
        sensor: !DepthCameraRig
          rate_hz: 15.0
          cameras:
          - {width: 80, height: 60, X_BC: {translation: [0.1, 0.0, -0.05],
             rotation: !Rpy {deg: [-90.0, 0.0, -90.0]}}}
          - {max_range: 3.0}
        """
    )
    rig = parse_scenario(path).sensor
    assert rig.rate_hz == 15.0 and rig.memory_s == DepthCamera().memory_s
    assert (rig.cameras[0].width, rig.cameras[1].max_range) == (80, 3.0)
    first, second = mounted_cameras(rig)
    np.testing.assert_allclose(first.X_MC.translation(), [0.1, 0.0, -0.05])
    np.testing.assert_allclose(
        second.X_MC.rotation().matrix(), R_LC.ToRotationMatrix().matrix(), atol=1e-12
    )


def test_the_rig3_preset_looks_ahead_and_to_both_sides():
    """scenarios/sensors/rig3.yaml, layered on a scenario: three cameras
    whose optical axes (camera z) are body +x, +y and −y, by hand from
    R = Rz Ry Rx: Rx(−90°) e_z = e_y, Rz(180°) e_y = −e_y."""
    override = read_override(os.path.join(SCENARIOS, "sensors", "rig3.yaml"))
    scenario = parse_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"), [override])
    rig = scenario.sensor
    assert isinstance(rig, DepthCameraRig) and rig.rate_hz == 20.0
    assert scenario.navigator.lag_drag
    axes = [m.X_MC.rotation().matrix()[:, 2] for m in mounted_cameras(rig)]
    np.testing.assert_allclose(axes, [[1, 0, 0], [0, 1, 0], [0, -1, 0]], atol=1e-12)
    assert [(c.width, c.height) for c in rig.cameras] == [
        (160, 120),
        (80, 60),
        (80, 60),
    ]


@pytest.mark.parametrize("pan,tilt", [(0.0, 0.0), (0.7, 0.3), (-2.5, -1.2)])
def test_the_gimbal_frame_is_pan_about_z_then_tilt_up(pan, tilt):
    # Drake's R = Rz(yaw) Ry(pitch) Rx(roll); raising the view is a negative pitch.
    R = RollPitchYaw(0.0, -tilt, pan).ToRotationMatrix().matrix()
    np.testing.assert_allclose(gimbal_rotation(pan, tilt), R, atol=1e-12)


def test_the_gimbal_turns_toward_the_velocity_at_its_slew_rate():
    degrees = np.radians
    # Unlimited: straight to the velocity's azimuth and elevation.
    np.testing.assert_allclose(
        point_gimbal(np.zeros(2), np.array([1.0, 1.0, math.sqrt(2.0)]), 10.0, 0.2),
        [math.pi / 4, math.pi / 4],
    )
    # Each axis moves at most max_step a call.
    np.testing.assert_allclose(
        point_gimbal(np.zeros(2), np.array([0.0, 1.0, -1.0]), 0.1, 0.2), [0.1, -0.1]
    )
    # The shorter way round: from 170° to −170° is +20°, through ±180°.
    start = degrees([170.0, 0.0])
    velocity = np.array([math.cos(degrees(-170.0)), math.sin(degrees(-170.0)), 0.0])
    np.testing.assert_allclose(
        point_gimbal(start, velocity, degrees(5.0), 0.2), degrees([175.0, 0.0])
    )
    np.testing.assert_allclose(
        point_gimbal(start, velocity, degrees(30.0), 0.2), degrees([-170.0, 0.0])
    )
    # Slower than min_speed: held; climbing straight up: the pan is held.
    held = np.array([0.4, 0.1])
    np.testing.assert_array_equal(
        point_gimbal(held, np.array([0.1, 0.1, 0.0]), 1.0, 0.2), held
    )
    np.testing.assert_allclose(
        point_gimbal(held, np.array([0.0, 0.1, 1.0]), 10.0, 0.2),
        [0.4, math.atan2(1.0, 0.1)],
    )


def test_a_gimballed_camera_sees_where_the_vehicle_climbs():
    # A sphere straight above: out of a forward camera's view. The estimate
    # says the vehicle climbs, so the gimbal tilts up at 180°/s: 90° in 15
    # frames. Stabilised, it looks up whatever the body's attitude.
    above = [(Sphere(radius=0.5), [0.3, 0.0, HEIGHT + 2.5])]
    climbing = state(velocity=(0.0, 0.0, 1.0))
    fixed = Rig(above)
    assert len(fixed.at(20.5 * FRAME, climbing)) == 0
    for attitude in [(0.0, 0.0, 0.0), (0.3, -0.2, 2.0)]:
        rig = Rig(above, DepthCamera(gimbal=Gimbal()))
        x = state(attitude=attitude, velocity=(0.0, 0.0, 1.0))
        assert len(rig.at(5.5 * FRAME, x)) == 0  # tilted 30°: not yet in view
        seen = rig.at(20.5 * FRAME, x)
        angles = rig.sensor.GetOutputPort("gimbal_angles").Eval(
            rig.sensor.GetMyContextFromRoot(rig.context)
        )
        np.testing.assert_allclose(angles, [0.0, math.pi / 2])
        tolerance = 3.0 * pixel_angle(DepthCamera())  # a pixel footprint at ≤ 3 m
        np.testing.assert_allclose(seen, rig.exact(x[:3]), atol=tolerance)


def test_a_gimballed_camera_places_what_it_sees_with_the_estimate():
    # The gimbal looking ahead (its start), the body tilted and yawed, and an
    # estimate 0.3 m to the left of the truth: every remembered sample lies
    # on the sphere moved 0.3 m to the left.
    centre = np.array([2.5, 0.4, HEIGHT])
    rig = Rig([(Sphere(radius=0.5), centre)], DepthCamera(gimbal=Gimbal()))
    x = state(attitude=(0.0, 0.1, 0.5))
    drifted = state(position=(0.0, 0.3, HEIGHT))
    assert len(rig.at(0.5 * FRAME, x, drifted)) == 1
    points = rig.sensor.percept(rig.sensor.GetMyContextFromRoot(rig.context))
    radii = np.linalg.norm(points.memory.points - (centre + [0.0, 0.3, 0.0]), axis=1)
    assert len(radii) > 10
    # Within the renderer's error here (VTK's depth and tessellation: up to
    # 1.5 cm at 2.5 m, as for a camera fixed to a level body).
    np.testing.assert_allclose(radii, 0.5, atol=0.02)


def test_renders_at_its_own_rate():
    scenario = load_scenario(os.path.join(SCENARIOS, "pelican_cylinder.yaml"))
    scenario.duration = 2.51
    flight = simulate(scenario)
    # Frames at k/rate for k = 0 … 75 (75/30 = 2.5 < 2.51).
    assert flight.frames_rendered == 76
    assert flight.metrics["frames_rendered"] == 76
    assert flight.metrics["sensor"] == "depth"
    assert flight.metrics["steps"] > flight.frames_rendered
    # The sample at t = 0 is logged before the first frame.
    obstacle = flight.log["obstacle"]
    np.testing.assert_array_equal(obstacle[0], np.zeros(OBSTACLE_SIGNAL_SIZE))
    assert np.all(obstacle[1:, 3] == 1.0)  # the cylinder is in view all along


@pytest.mark.parametrize("mount", ["{}", "null"], ids=["gimbal", "fixed"])
@pytest.mark.parametrize("name", ["pelican_cylinder", "pelican_cube"])
def test_pelican_fig11_flight_succeeds_with_the_depth_camera(
    name, mount, tmp_path, capsys
):
    path = os.path.join(SCENARIOS, f"{name}.yaml")
    assert isinstance(load_scenario(path).sensor, DepthCamera)
    mounted = ["--set", f"sensor: !DepthCamera {{gimbal: {mount}}}"]
    assert main(["run", path, *mounted, "--json", "--out", str(tmp_path)]) == 0
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
    held = simulate(scenario)
    assert following.metrics["success"] and following.metrics["min_clearance"] > 0
    assert held.metrics["collided"]  # looking along +x it never sees it in time
    first_seen = [
        f.times[np.argmax(f.log["obstacle"][:, 3] > 0.5)] for f in (following, held)
    ]
    assert first_seen[0] < 1.0 < 3.0 < first_seen[1]


def test_a_gimballed_camera_sees_a_side_obstacle_with_the_yaw_held():
    scenario = load_scenario(os.path.join(SCENARIOS, "pelican_side_goal.yaml"))
    scenario.navigator.yaw_follows_motion = False
    scenario.sensor.gimbal = Gimbal()
    flight = simulate(scenario)
    assert flight.metrics["success"] and flight.metrics["min_clearance"] > 0
    assert flight.times[np.argmax(flight.log["obstacle"][:, 3] > 0.5)] < 1.0


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
sensor: {SENSOR}
"""


@pytest.mark.parametrize(
    "sensor,name,value",
    [
        ("!DepthCamera {width: 0}", "sensor.width", "0"),
        ("!DepthCamera {height: -120}", "sensor.height", "-120"),
        ("!DepthCamera {width: 160.5}", "sensor.width", "160.5"),
        ("!DepthCamera {fov_y_deg: 180.0}", "sensor.fov_y_deg", "180.0"),
        ("!DepthCamera {fov_y_deg: 0.0}", "sensor.fov_y_deg", "0.0"),
        ("!DepthCamera {fov_y_deg: -10.0}", "sensor.fov_y_deg", "-10.0"),
        ("!DepthCamera {max_range: 0.0}", "sensor.max_range", "0.0"),
        ("!DepthCamera {max_range: .inf}", "sensor.max_range", "inf"),
        ("!DepthCamera {rate_hz: -30.0}", "sensor.rate_hz", "-30.0"),
        ("!DepthCamera {rate_hz: 0.0}", "sensor.rate_hz", "0.0"),
        ("!DepthCamera {memory_s: 0.0}", "sensor.memory_s", "0.0"),
        ("!DepthCamera {position: [0.1, 0.0]}", "sensor.position", "[0.1, 0.0]"),
        ("!DepthCamera {rpy_deg: [0.0, .nan, 0.0]}", "sensor.rpy_deg", "nan"),
        ("!DepthCamera {colour: true}", "sensor.colour", "True"),
        ("!DepthCameraRig {cameras: []}", "sensor.cameras", "[]"),
        (
            "!DepthCameraRig {cameras: [{}, {width: 0}]}",
            "sensor.cameras[1].width",
            "0",
        ),
        (
            "!DepthCameraRig {cameras: [{fov_y_deg: 200}]}",
            "cameras[0].fov_y_deg",
            "200",
        ),
        ("!DepthCameraRig {cameras: [{fps: 30}]}", "sensor.cameras[0].fps", "30"),
        (
            "!DepthCameraRig {cameras: [{X_BC: {translaton: [0, 0, 0]}}]}",
            "sensor.cameras[0].X_BC.translaton",
            "[0, 0, 0]",
        ),
        (
            "!DepthCameraRig {cameras: [{X_BC: {base_frame: world}}]}",
            "sensor.cameras[0].X_BC.base_frame",
            "'world'",
        ),
        ("!DepthCameraRig {rate_hz: -1}", "sensor.rate_hz", "-1"),
        ("!DepthCamera {gimbal: {rate_deg_s: 0}}", "sensor.gimbal.rate_deg_s", "0"),
        ("!DepthCamera {gimbal: {min_speed: -1}}", "sensor.gimbal.min_speed", "-1"),
        ("!DepthCamera {gimbal: {slew: 3}}", "sensor.gimbal.slew", "3"),
        ("!DepthCamera {gimbal: [1, 2]}", "sensor.gimbal", "[1, 2]"),
    ],
)
def test_bad_camera_configurations_are_one_line_and_exit_status_2(
    write_yaml, capsys, tmp_path, sensor, name, value
):
    path = write_yaml(CAMERA.replace("{SENSOR}", sensor))
    assert main(["run", path, "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and f"{name} = " in error and value in error
    assert not os.path.exists(tmp_path / "out")
