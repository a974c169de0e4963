"""Dynamic scenes (docs/dynamic.md): moving obstacles against the closed form
of their motion, exact clearance to moving geometry, the ground, the
velocity estimate from successive readings, several vehicles and their run
JSON, and every bad input of these formats as one line with exit status 2."""

import dataclasses
import json
import os
import sys
from functools import partial

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder, LeafSystem

from mfi_drake.app.cli import main
from mfi_drake.app.figures import plot_flights
from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground, Motion, OtherVehicle, RelativeVelocity
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.result import outcome
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    OBSTACLE_SIGNAL_SIZE,
    STATE_SIZE,
    obstacle_signal,
    seen_points,
)
from mfi_drake.maths.motion import (
    displacement,
    displacement_rate,
    keep_own_pace,
    match_points,
)
from mfi_drake.studies.records import read_results
from mfi_drake.studies.sweep import SweepConfig, run_sweep
from mfi_drake.studies.variants import motion_variant, with_overrides
from mfi_drake.systems.navigation import MfiNavigator
from mfi_drake.systems.relative import ObstacleVelocityEstimator, relative_navigator
from mfi_drake.world.generator import random_field, set_in_motion
from mfi_drake.world.motion import obstacle_position
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

WANDER = Motion(
    velocity=[0.05, 0.10, 0.03],
    amplitude=[0.9, 1.1, 0.7],
    angular_frequency=[0.7, 1.15, 0.95],
    phase=[0.2, 1.1, 2.0],
)


def test_motion_is_the_closed_form_per_component():
    obstacle = sc.Obstacle(sc.Sphere(1.2), [6.4, 0.0, 0.6], motion=WANDER)
    for t in [0.0, 0.37, 5.0, 31.4]:
        expected = [
            p + v * t + a * np.sin(w * t + phi)
            for p, v, a, w, phi in zip(
                [6.4, 0.0, 0.6],
                *(getattr(WANDER, k) for k in vars(WANDER)),
                strict=True,
            )
        ]
        np.testing.assert_allclose(obstacle_position(obstacle, t), expected, atol=1e-15)
    times = np.linspace(0.0, 10.0, 7)
    np.testing.assert_allclose(
        obstacle_position(obstacle, times),
        [obstacle_position(obstacle, t) for t in times],
        atol=1e-15,
    )
    # The rate is the derivative (central differences).
    args = [getattr(WANDER, k) for k in vars(WANDER)]
    h = 1e-6
    for t in [0.3, 7.0]:
        numeric = (displacement(*args, t + h) - displacement(*args, t - h)) / (2 * h)
        np.testing.assert_allclose(displacement_rate(*args, t), numeric, atol=1e-8)
    # Without a motion, or with zeros, the obstacle stays where it is, exactly.
    still = sc.Obstacle(sc.Sphere(1.0), [1.0, 2.0, 3.0], motion=Motion())
    assert obstacle_position(still, 12.5).tolist() == [1.0, 2.0, 3.0]


def test_clearance_to_a_moving_sphere_is_exact_at_every_time():
    obstacle = sc.Obstacle(sc.Sphere(0.5), [2.0, 1.0, 1.5], motion=WANDER)
    scenario = sc.Scenario(obstacles=[obstacle])
    rng = np.random.default_rng(3)
    points = rng.uniform(-1.0, 4.0, (20, 3))
    times = rng.uniform(0.0, 30.0, 20)
    got = obstacle_distances(scenario, points, times=times)
    centres = [obstacle_position(obstacle, t) for t in times]
    expected = np.linalg.norm(points - centres, axis=1) - 0.5
    np.testing.assert_allclose(got, expected, atol=1e-12)
    # A reach leaves the far ones at inf.
    near = obstacle_distances(scenario, points, 1.0, times)
    assert all(
        g == e or (e >= 1.0 and g == np.inf) for g, e in zip(near, got, strict=True)
    )


def test_flight_clearance_to_a_moving_obstacle_is_the_closed_form(tmp_path):
    scenario = load_scenario(os.path.join(SCENARIOS, "moving_head_on.yaml"))
    scenario.duration = 12.0
    flight = simulate(scenario)
    plot_flights(scenario, [flight], str(tmp_path / "moving.png"))
    assert (tmp_path / "moving.png").stat().st_size > 0
    centres = obstacle_position(scenario.obstacles[0], flight.times)
    distance = np.linalg.norm(flight.positions - centres, axis=1) - 0.6
    exact = distance.min() - flight.collision_radius
    assert flight.metrics["min_clearance"] == pytest.approx(exact, abs=1e-12)
    # The sensor saw the sphere where it was: reading = closest point.
    k = int(np.argmin(distance))
    r_o = flight.log["obstacle"][k, :3]
    to_centre = centres[k] - flight.positions[k]
    expected = to_centre * (1.0 - 0.6 / np.linalg.norm(to_centre))
    np.testing.assert_allclose(r_o, expected, atol=1e-9)


class _Readings(LeafSystem):
    """The readings of a vehicle at rest at the origin looking at
    `points_of_time(t)`, a list of points."""

    def __init__(self, points_of_time):
        super().__init__()
        self.DeclareVectorOutputPort(
            "obstacle",
            OBSTACLE_SIGNAL_SIZE,
            lambda context, out: out.SetFromVector(
                obstacle_signal(points_of_time(context.get_time()))
            ),
            prerequisites_of_calc={self.time_ticket()},
        )


def _estimate_at_1s(points_of_time, rate_hz=20.0, tau=0.0):
    builder = DiagramBuilder()
    estimator = builder.AddSystem(ObstacleVelocityEstimator(rate_hz, tau, 0.3))
    readings = builder.AddSystem(_Readings(points_of_time))
    builder.Connect(readings.get_output_port(), estimator.GetInputPort("obstacle"))
    builder.ExportInput(estimator.GetInputPort("state"), "state")
    builder.ExportOutput(estimator.GetOutputPort("obstacle_velocity"), "u")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    diagram.GetInputPort("state").FixValue(context, np.zeros(STATE_SIZE))
    simulator.AdvanceTo(1.0)
    return diagram.GetOutputPort("u").Eval(context)


def test_the_estimate_is_the_normal_velocity_and_zero_for_static_obstacles():
    # A sphere of radius 0.5 centred at c(t) = (3, 1, 0) + u t: the closest
    # point to the origin moves with it, plus sliding over the surface.
    u = np.array([-0.8, 0.3, 0.1])

    def sphere(t):
        c = np.array([3.0, 1.0, 0.0]) + u * t
        return [c * (1.0 - 0.5 / np.linalg.norm(c))]

    got = _estimate_at_1s(sphere)[:3]
    r_o = sphere(1.0)[0]
    n = r_o / np.linalg.norm(r_o)
    np.testing.assert_allclose(got, n * (n @ u), atol=0.01)
    # Two static points: nothing moves, nothing estimated; nothing seen: 0.
    static = _estimate_at_1s(lambda t: [np.array([1.0, 0, 0]), np.array([0, 2.0, 0])])
    np.testing.assert_array_equal(static, np.zeros(3 * OBSTACLE_COUNT))


def test_readings_are_matched_to_the_nearest_earlier_point_within_the_gate():
    before = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    now = np.array([[1.05, 0, 0], [0.02, 0, 0], [5.0, 0, 0]])
    assert match_points(now, before, 0.3) == [1, 0, None]
    assert match_points(now, np.zeros((0, 3)), 0.3) == [None] * 3


def test_own_pace_keeps_the_own_fields_part_along_v():
    v = np.array([2.0, 0.0, 0.0])
    relative, own = np.array([1.0, 2.0, 3.0]), np.array([-4.0, 0.0, 0.0])
    np.testing.assert_allclose(keep_own_pace(relative, own, v, 0.3), [-4.0, 2.0, 3.0])
    # At rest the own field acts alone; below the blend speed, in part.
    np.testing.assert_allclose(keep_own_pace(relative, own, 0 * v, 0.3), own)
    slow = keep_own_pace(relative, own, np.array([0.15, 0, 0]), 0.3)
    np.testing.assert_allclose(slow, [-4.0, 1.0, 1.5])


@pytest.mark.parametrize("own_pace", [True, False])
def test_relative_navigator_is_the_navigator_when_nothing_moves(own_pace):
    """With every estimate zero, the per-reading navigators add up to the
    plain navigator (its field is a sum over readings)."""
    params = sc.Scenario().navigator
    goal = [10.0, 0.0, 2.0]
    plain = MfiNavigator(params, goal, 0.225)
    estimate = RelativeVelocity(own_pace=own_pace)
    combined = relative_navigator(
        lambda: MfiNavigator(params, goal, 0.225), estimate, 20
    )
    x = np.zeros(STATE_SIZE)
    x[:3], x[6:9] = [1.0, 0.2, 2.0], [0.9, 0.1, 0.05]
    obstacle = obstacle_signal([[0.8, 0.3, 0.0], [0.2, -1.0, 0.1], [0.0, 0.0, -1.2]])
    outputs = []
    for system in (plain, combined):
        context = system.CreateDefaultContext()
        system.GetInputPort("state").FixValue(context, x)
        system.GetInputPort("obstacle").FixValue(context, obstacle)
        outputs.append(
            [
                system.GetOutputPort(p).Eval(context)
                for p in ("obstacle_force", "obstacle_force_terms")
            ]
        )
    for got, want in zip(outputs[1], outputs[0], strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_a_static_scene_builds_the_static_diagram():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    diagram = build_diagram(scenario).diagram
    names = {s.get_name() for s in diagram.GetSystems()}
    assert "obstacle_motion" not in names and "quadrotor_1" not in names
    assert not isinstance(diagram.GetSubsystemByName("navigator"), Diagram)
    moving = load_scenario(os.path.join(SCENARIOS, "moving_head_on.yaml"))
    diagram = build_diagram(moving).diagram
    assert isinstance(diagram.GetSubsystemByName("navigator"), Diagram)
    assert diagram.HasSubsystemNamed("obstacle_motion")


MOVING = ["moving_head_on", "moving_crossing", "moving_wandering"]
CAMERA = ("--set", "sensor: !DepthCamera {}")


@pytest.mark.parametrize("camera", [False, True], ids=["sphere", "camera"])
@pytest.mark.parametrize("name", MOVING)
def test_moving_obstacles_are_passed_without_contact(name, camera):
    path = os.path.join(SCENARIOS, f"{name}.yaml")
    scenario = load_scenario(path, [CAMERA] if camera else [])
    flight = simulate(scenario)
    assert flight.metrics["success"], flight.metrics
    # It is in the way: its centre comes onto the start–goal line.
    obstacle = scenario.obstacles[0]
    line = np.linspace(scenario.start, scenario.goal, 400)
    centres = obstacle_position(obstacle, flight.times)
    gaps = np.linalg.norm(line[None, :, :] - centres[:, None, :], axis=2)
    assert gaps.min() < obstacle.shape.radius


def test_the_sensor_sees_the_ground_and_the_clearance_counts_it(write_yaml):
    path = write_yaml(
        """\
        name: ground
        start: [0.0, 0.0, 1.0]
        goal: [6.0, 0.0, 1.0]
        duration: 10.0
        ground: {height: 0.2}
        """
    )
    scenario = load_scenario(path)
    flight = simulate(scenario)
    # The ground is a box under the plane (world.obstacles.GROUND_WIDTH):
    # its distance rounds through the box's centre, 50 m down.
    reading = flight.log["obstacle"][0, :4]
    np.testing.assert_allclose(reading, [0.0, 0.0, -0.8, 1.0], rtol=0, atol=1e-13)
    above = flight.positions[:, 2] - 0.2 - flight.collision_radius
    assert flight.metrics["min_clearance"] == pytest.approx(above.min(), abs=1e-12)
    assert flight.metrics["success"]


@pytest.mark.parametrize("method", ["mfi", "apf", "gf"])
def test_flights_over_the_ground_stay_above_it(method):
    scenario = load_scenario(os.path.join(SCENARIOS, "tree_on_ground.yaml"))
    flight = simulate(scenario, method)
    lowest = flight.positions[:, 2].min() - scenario.ground.height
    assert lowest > flight.collision_radius


def test_tree_on_ground_flies_in_few_steps_with_a_brake_margin():
    # Braking at the tilt limit, the turn runs along it and the sharp rule
    # (margin 0, the default) switches it on and off: 4692 steps, 3000 of
    # them of 20–60 µs in 0.16 s. A margin of 0.1 keeps the braking inside
    # the limit: 1612.
    path = os.path.join(SCENARIOS, "tree_on_ground.yaml")
    steps = {
        margin: simulate(
            load_scenario(path, [("m", f"navigator: {{brake_margin: {margin}}}")]),
            "mfi-memoryless",  # the field alone: the corner brake smooths it too
        ).metrics["steps"]
        for margin in (0.0, 0.1)
    }
    assert steps[0.1] < 2000 < 3500 < steps[0.0]


def test_four_vehicles_swap_antipodal_positions():
    flight = simulate(load_scenario(os.path.join(SCENARIOS, "swarm_circle.yaml")))
    assert all(v["reached"] for v in flight.metrics["vehicles"])
    assert flight.metrics["min_separation"] > 0.0
    assert flight.metrics["success"]


def test_two_vehicles_run_json_has_every_vehicle_and_the_separation(capsys, tmp_path):
    path = os.path.join(SCENARIOS, "swarm_corridor.yaml")
    assert (
        main(["run", path, "--json", "--out", str(tmp_path), "--set", "duration: 14"])
        == 0
    )
    metrics = json.loads(capsys.readouterr().out)
    assert len(metrics["vehicles"]) == 2
    for vehicle in metrics["vehicles"]:
        assert {
            "success",
            "reached",
            "collided",
            "min_clearance",
            "path_length",
        } <= set(vehicle)
    first = metrics["vehicles"][0]
    for key in ("reached", "collided", "min_clearance", "path_length"):
        assert metrics[key] == first[key]  # the first vehicle's keys are kept
    assert metrics["min_separation"] > 0
    assert metrics["success"] == all(v["success"] for v in metrics["vehicles"])
    assert (tmp_path / "trajectory.png").stat().st_size > 0  # every vehicle drawn
    assert metrics["outcome"] == "success"


def test_success_needs_every_vehicle_and_room_between_them():
    one = {"success": True, "reached": True, "collided": False}
    metrics = {**one, "vehicles": [one, one], "min_separation": 0.1}
    assert outcome(metrics) == "success"
    assert outcome({**metrics, "min_separation": -0.01}) == "collision"
    late = {**one, "reached": False, "success": False}
    assert outcome({**metrics, "vehicles": [one, late]}) == "timeout"


def test_moving_fields_move_a_share_at_the_speed_and_keep_clear_of_the_ends():
    field = random_field(2026, 3, 0.1)
    moving = set_in_motion(field, 2026, 3, 0.3, 0.5)
    moved = [o for o in moving.obstacles if o.motion is not None]
    assert len(moved) == round(0.3 * len(field.obstacles))
    times = np.linspace(0.0, 60.0, 241)
    for obstacle in moved:
        m = obstacle.motion
        rate = displacement_rate(
            m.velocity, m.amplitude, m.angular_frequency, m.phase, times
        )
        np.testing.assert_allclose(np.linalg.norm(rate, axis=1), 0.5, rtol=1e-9)
        alone = sc.Scenario(obstacles=[obstacle])
        for end in (field.start, field.goal):
            gap = obstacle_distances(alone, [end] * len(times), times=times)
            assert min(gap) >= 0.225 + 0.5 - 1e-9
    # The same obstacles as the static field, where they were drawn.
    assert [o.shape for o in moving.obstacles] == [o.shape for o in field.obstacles]


GOOD = """\
name: bad
start: [0.0, 0.0, 1.5]
goal: [6.0, 0.0, 1.5]
duration: 10.0
obstacles:
  - shape: !Sphere {radius: 0.5}
    position: [3.0, 2.0, 1.5]
    motion: {velocity: [0.0, 0.1, 0.0]}
ground: {height: 0.0}
other_vehicles:
  - {start: [6.0, 1.0, 1.5], goal: [0.0, 1.0, 1.5]}
"""

BAD = [
    ("NaN motion", ("[0.0, 0.1, 0.0]", "[.nan, 0.1, 0.0]"), "motion.velocity"),
    (
        "infinite motion",
        ("velocity: [0.0, 0.1, 0.0]", "amplitude: [.inf, 0, 0]"),
        "motion.amplitude",
    ),
    (
        "negative frequency",
        ("velocity: [0.0, 0.1, 0.0]", "angular_frequency: [0, -1.0, 0]"),
        "motion.angular_frequency",
    ),
    (
        "start below ground",
        ("ground: {height: 0.0}", "ground: {height: 2.0}"),
        "ground",
    ),
    (
        "start on the ground",
        ("ground: {height: 0.0}", "ground: {height: 1.3}"),
        "start",
    ),
    (
        "NaN ground",
        ("ground: {height: 0.0}", "ground: {height: .nan}"),
        "ground.height",
    ),
    (
        "other vehicle in an obstacle",
        ("start: [6.0, 1.0, 1.5]", "start: [3.0, 2.1, 1.5]"),
        "other_vehicles[0].start",
    ),
    (
        "vehicles too close",
        ("start: [6.0, 1.0, 1.5]", "start: [0.2, 0.3, 1.5]"),
        "other_vehicles[0].start",
    ),
    (
        "shared goal",
        ("goal: [0.0, 1.0, 1.5]", "goal: [6.0, 0.0, 1.5]"),
        "other_vehicles[0].goal",
    ),
    (
        "other vehicle's NaN",
        ("goal: [0.0, 1.0, 1.5]", "goal: [0.0, .nan, 1.5]"),
        "other_vehicles[0].goal",
    ),
    (
        "rule of the road at 90 degrees",
        ("ground: {height: 0.0}", "relative_velocity: {keep_right: 90.0}"),
        "relative_velocity.keep_right = 90.0",
    ),
    (
        "other vehicle without goal",
        (", goal: [0.0, 1.0, 1.5]", ""),
        "other_vehicles[0].goal: missing",
    ),
]


@pytest.mark.parametrize("label, change, needle", BAD, ids=[b[0] for b in BAD])
def test_bad_dynamic_input_is_one_line_and_exit_2(
    write_yaml, tmp_path, capsys, label, change, needle
):
    assert load_scenario(write_yaml(GOOD)).other_vehicles  # the base is good
    path = write_yaml(GOOD.replace(*change))
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("mfi-drake: error:")
    assert path in err and needle in err
    assert not out.exists()


def test_a_vehicles_camera_sees_the_other_vehicle_and_not_itself(write_yaml):
    # Two vehicles 3 m apart on the x axis, the first looking along +x at the
    # second, which looks back; nothing else in the scene.
    text = """\
name: two_cameras
start: [0.0, 0.0, 1.5]
goal: [0.0, 4.0, 1.5]
duration: 0.05
sensor: !DepthCamera {}
other_vehicles:
  - {start: [3.0, 0.0, 1.5], goal: [3.0, -4.0, 1.5]}
"""
    flight = simulate(load_scenario(write_yaml(text)))
    r = flight.collision_radius
    seen = np.linalg.norm(seen_points(flight.log["obstacle"][-1]), axis=1)
    # The other's sphere, its nearest point 3 − r from this centre; the own
    # sphere, which its camera is inside, is clipped, not read at r.
    assert len(seen) == 1 and seen[0] == pytest.approx(3.0 - r, abs=0.03)
    assert OtherVehicle().start != OtherVehicle().goal and Ground().height == 0.0


def test_two_vehicles_on_cameras_swap_the_corridor():
    path = os.path.join(SCENARIOS, "swarm_corridor.yaml")
    scenario = load_scenario(path, [("--set", "sensor: !DepthCamera {}")])
    flight = simulate(scenario)
    assert all(v["reached"] and not v["collided"] for v in flight.metrics["vehicles"])
    assert flight.metrics["min_separation"] > 0.0


def test_a_sweep_with_moving_obstacles_keys_and_counts_them(tmp_path, threads_client):
    config = SweepConfig(
        n=1,
        seed=7,
        methods=["mfi"],
        out=str(tmp_path),
        moving=0.3,
        obstacle_speed=0.5,
        variant=motion_variant(0.3, 0.5),
    )
    run = run_sweep(
        config,
        threads_client,
        modify=partial(with_overrides, overrides=[("short", "duration: 2.0")]),
        progress_stream=sys.stdout,
    )
    assert (run.ran, run.lost) == (1, [])
    (record,) = read_results(str(tmp_path / "results.jsonl"))
    assert record["variant"] == "moving=0.3,obstacle_speed=0.5"
    assert record["moving"] == round(0.3 * record["obstacles"])


@pytest.mark.parametrize(
    "args, named",
    [
        (["--moving", "1.5", "--obstacle-speed", "0.5"], "--moving"),
        (["--moving", "nan", "--obstacle-speed", "0.5"], "--moving"),
        (["--moving", "0.3"], "--obstacle-speed"),
        (["--moving", "0.3", "--obstacle-speed", "inf"], "--obstacle-speed"),
    ],
)
def test_sweep_rejects_bad_motion_arguments(tmp_path, capsys, args, named):
    assert main(["sweep", "--out", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and named in err


def test_a_fleet_among_moving_obstacles_flies_with_the_rule_of_the_road(write_yaml):
    # The estimate's navigator (a diagram) must read which readings are
    # vehicles: built and flown, its input is connected.
    scenario = load_scenario(write_yaml(GOOD))
    assert scenario.relative_velocity.keep_right > 0.0
    flight = simulate(dataclasses.replace(scenario, duration=0.5))
    assert len(flight.others) == 1 and flight.metrics["sim_time"] == 0.5
