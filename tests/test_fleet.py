"""Fleets: the exchange, the scene generator, validation of moving obstacles
over goals, a small antipodal swap and the multi-vehicle sweep."""

import dataclasses
import math
import sys
import warnings

import numpy as np
import pytest
from pydrake.geometry import GeometryInstance, RenderLabel, Rgba, SceneGraph
from pydrake.geometry import Sphere as DrakeSphere
from pydrake.math import RigidTransform

from mfi_drake.app.cli import main
from mfi_drake.app.figures import plot_fleet_sweep
from mfi_drake.app.flight_commands import summary_line
from mfi_drake.app.flight_log import write_flight_log
from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Motion, OtherVehicle
from mfi_drake.config.scenario_yaml import scenario_to_yaml
from mfi_drake.flight.diagram import vehicle_scenarios
from mfi_drake.flight.result import least_separation
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths.layout import obstacle_signal, readings
from mfi_drake.maths.motion import turned_right
from mfi_drake.studies import fleet_sweep, sweep
from mfi_drake.studies.records import read_results
from mfi_drake.systems.exchange import extrapolated, merge, message
from mfi_drake.systems.navigation import MfiNavigator
from mfi_drake.systems.relative import RelativeNavigator
from mfi_drake.world import generator
from mfi_drake.world.fleets import (
    PAIR_GAP,
    antipodal_circle,
    crossing_streams,
    random_pairs,
)
from mfi_drake.world.obstacles import nearest_obstacles, sensed
from mfi_drake.world.validation import (
    ScenarioWarning,
    load_scenario,
    validate_scenario,
)


# --- the exchange ---------------------------------------------------------------
def test_message_carries_the_others_in_fleet_order_and_extrapolates_linearly():
    positions = [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [0.0, 3.0, 1.0]]
    velocities = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]
    received = message(4.0, positions, velocities, 1)  # vehicle 1 hears 0 and 2
    assert received.tolist() == [4.0, 0, 0, 1, 0, 3, 1, 1, 0, 0, 0, 0, -1]
    centres, v = extrapolated(received, 4.5)
    assert centres.tolist() == [[0.5, 0.0, 1.0], [0.0, 3.0, 0.5]]
    assert v.tolist() == [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]


def test_merge_reads_a_received_sphere_as_the_hand_computation_and_scene_graph():
    # Another vehicle at (2, 0, 0) at t = 0 moving at (0, 1, 0); at t = 0.5
    # it is at (2, 0.5, 0): d = (2, 0.5, 0), |d| = √4.25, gap |d| − 0.2.
    received = message(0.0, [[0, 0, 0], [2, 0, 0]], [[0, 0, 0], [0, 1, 0]], 0)
    wall = [0.0, 0.0, -2.5]  # a nearer-first order: the sphere, then this
    scene = obstacle_signal([wall])
    signal, u, vehicle = merge(np.zeros(3), scene, received, 0.5, 0.2, 3.0)
    (first, seen_1), (second, seen_2), (_, seen_3) = readings(signal)
    assert vehicle.tolist() == [1.0, 0.0, 0.0]  # the sphere, not the wall
    gap = math.sqrt(4.25) - 0.2
    n = np.array([2.0, 0.5, 0.0]) / math.sqrt(4.25)
    np.testing.assert_allclose(first, gap * n, atol=1e-12)
    assert (seen_1, seen_2, seen_3) == (1.0, 1.0, 0.0)
    np.testing.assert_array_equal(second, wall)
    np.testing.assert_allclose(u[:3], n * n[1], atol=1e-12)  # v along n
    np.testing.assert_array_equal(u[3:], 0.0)  # the scene's reading is static
    # SceneGraph reads a sphere at that centre the same way.
    scene_graph = SceneGraph()
    source = scene_graph.RegisterSource("test")
    sphere = GeometryInstance(RigidTransform([2.0, 0.5, 0.0]), DrakeSphere(0.2), "s")
    sensed(sphere, Rgba(1, 1, 1, 1), RenderLabel(1))
    scene_graph.RegisterAnchoredGeometry(source, sphere)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    reference = readings(nearest_obstacles(query, np.zeros(3), 3.0))[0][0]
    np.testing.assert_allclose(first, reference, atol=1e-12)


def test_merge_passes_the_scene_through_when_no_vehicle_is_in_reach():
    received = message(0.0, [[0, 0, 0], [9, 0, 0]], np.zeros((2, 3)), 0)
    scene = obstacle_signal([[1.0, 0.0, 0.0]])
    signal, u, vehicle = merge(np.zeros(3), scene, received, 0.0, 0.2, 3.0)
    assert signal is scene and not u.any() and not vehicle.any()


def test_each_vehicle_sees_every_other_in_fleet_order():
    scene = antipodal_circle(3)
    flown = vehicle_scenarios(scene)
    assert [s.start for s in flown] == [scene.start] + [
        o.start for o in scene.other_vehicles
    ]
    assert [o.start for o in flown[1].other_vehicles] == [
        flown[0].start,
        flown[2].start,
    ]


# --- scenes and validation --------------------------------------------------------
@pytest.mark.parametrize(
    "scene", [antipodal_circle(2), antipodal_circle(32), crossing_streams(7)]
)
def test_generated_scenes_validate_with_starts_and_goals_apart(scene):
    validate_scenario(scene, scene.name)
    for ends in ("start", "goal"):
        points = [getattr(scene, ends)] + [
            getattr(o, ends) for o in scene.other_vehicles
        ]
        gaps = [math.dist(a, b) for i, a in enumerate(points) for b in points[:i]]
        assert min(gaps) >= 1.0


def test_random_pairs_are_apart_clear_and_meet_head_on():
    field = generator.random_field(3, 0, 0.2)
    scene = random_pairs(field, 6, 3, 0)
    validate_scenario(scene, scene.name)
    ends = [(scene.start, scene.goal)] + [
        (o.start, o.goal) for o in scene.other_vehicles
    ]
    assert [s[0] for s, _ in ends] == [0.0, 10.0] * 3  # half each way
    for k in (0, 1):
        points = [e[k] for e in ends]
        assert (
            min(math.dist(a, b) for i, a in enumerate(points) for b in points[:i])
            >= PAIR_GAP
        )
    assert scene.obstacles == field.obstacles


def _written(tmp_path, *argv) -> sc.Scenario:
    path = str(tmp_path / "scene.yaml")
    assert main(["scene", *argv, "--out", path]) == 0
    return load_scenario(path)


def test_scene_circle_puts_the_vehicles_evenly_and_sends_each_across(tmp_path):
    scene = _written(tmp_path, "circle", "--vehicles", "5", "--radius", "4")
    ends = [(scene.start, scene.goal)] + [
        (o.start, o.goal) for o in scene.other_vehicles
    ]
    for k, (start, goal) in enumerate(ends):  # the closed form, by hand
        a = 2.0 * math.pi * k / 5
        assert start == pytest.approx([4.0 * math.cos(a), 4.0 * math.sin(a), 2.0])
        assert goal == pytest.approx([-start[0], -start[1], 2.0])
    assert scene.duration == 40.0  # 5 s per metre of its 8 m diameter


def test_scene_streams_cross_at_right_angles(tmp_path):
    scene = _written(tmp_path, "streams", "--vehicles", "4", "--length", "10")
    ends = [(scene.start, scene.goal)] + [
        (o.start, o.goal) for o in scene.other_vehicles
    ]
    directions = {tuple(np.subtract(g, s)) for s, g in ends}
    assert directions == {(10.0, 0.0, 0.0), (0.0, 10.0, 0.0)}


@pytest.mark.parametrize("vehicles", [1, 3])
def test_scene_field_is_the_field_the_sweep_flies(tmp_path, vehicles):
    argv = ["field", "--vehicles", str(vehicles), "--seed", "4", "--index", "2"]
    scene = _written(tmp_path, *argv, "--density", "0.2")
    config, tasks = (
        (sweep.SweepConfig(seed=4), sweep.SINGLE)
        if vehicles == 1
        else (
            fleet_sweep.FleetSweepConfig(seed=4, vehicles=vehicles),
            fleet_sweep.FLEET,
        )
    )
    flown = generator.self_contained(tasks.make_field(config, 0.2, 2))
    assert scenario_to_yaml(dataclasses.replace(scene, base_dir="")) == (
        scenario_to_yaml(flown)
    )


@pytest.mark.parametrize(
    "argv, named",
    [
        (["field", "--radius", "3"], "--radius = 3.0: shapes a circle scene only"),
        (["circle", "--seed", "2"], "--seed = 2: shapes a field scene only"),
        (["field", "--height", "3"], "--height = 3.0: shapes a circle or streams"),
        (["circle", "--vehicles", "0"], "--vehicles = 0: must be ≥ 1"),
        (["circle", "--radius", "-1"], "--radius = -1.0: must be a finite number > 0"),
        (["field", "--index", "-1"], "--index = -1: must be ≥ 0"),
        (
            ["field", "--vehicles", "2", "--goal-clearance", "0.3"],
            "not with --vehicles",
        ),
        (["circle", "--radius", "0.5"], "other_vehicles[0].start"),  # too close
    ],
)
def test_a_bad_scene_is_one_line_and_writes_nothing(tmp_path, capsys, argv, named):
    path = tmp_path / "scene.yaml"
    assert main(["scene", *argv, "--out", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err, err
    assert not path.exists()


def _scene(obstacle: sc.Obstacle, **ends) -> sc.Scenario:
    base = {"start": [0.0, 0.0, 2.0], "goal": [6.0, 0.0, 2.0]} | ends
    return sc.Scenario(name="t", obstacles=[obstacle], duration=20.0, **base)


def _sphere(position, motion=None) -> sc.Obstacle:
    return sc.Obstacle(
        shape=sc.Sphere(radius=0.5), position=position, rpy_deg=[0, 0, 0], motion=motion
    )


AWAY = Motion(velocity=[0.0, 0.5, 0.0])  # leaves the goal within ~1.4 s
IN_PLACE = Motion(amplitude=[0.1, 0.0, 0.0], angular_frequency=[1.0, 0, 0])


def test_a_start_inside_a_moving_obstacle_at_t0_is_refused():
    with pytest.raises(sc.ScenarioError, match=r"t: start = .*from an obstacle"):
        validate_scenario(_scene(_sphere([0.0, 0.0, 2.0], AWAY)), "t")


def test_a_goal_under_a_static_obstacle_is_refused():
    with pytest.raises(sc.ScenarioError, match=r"t: goal = .*from an obstacle"):
        validate_scenario(_scene(_sphere([6.0, 0.0, 2.0])), "t")


def test_a_goal_a_moving_obstacle_leaves_is_valid_with_a_warning():
    with pytest.warns(ScenarioWarning, match=r"goal = .* moves off by t = 1\.\d"):
        validate_scenario(_scene(_sphere([6.0, 0.0, 2.0], AWAY)), "t")


def test_a_goal_a_moving_obstacle_never_leaves_is_refused():
    with pytest.raises(sc.ScenarioError, match=r"goal = .*throughout the flight"):
        validate_scenario(_scene(_sphere([6.0, 0.0, 2.0], IN_PLACE)), "t")


def test_a_moving_obstacle_away_from_the_goal_gives_no_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_scenario(_scene(_sphere([3.0, 3.0, 2.0], AWAY)), "t")


def test_an_other_vehicles_goal_is_judged_the_same_way():
    scene = _scene(
        _sphere([6.0, 3.0, 2.0], IN_PLACE),
        other_vehicles=[OtherVehicle([0.0, 3.0, 2.0], [6.0, 3.0, 2.0])],
    )
    with pytest.raises(sc.ScenarioError, match=r"other_vehicles\[0\]\.goal = "):
        validate_scenario(scene, "t")


# --- flights ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def swap():
    """Three vehicles swapping antipodal points of a 3 m circle (~12 s)."""
    return simulate(antipodal_circle(3, radius=3.0, duration=14.0))


def test_a_small_antipodal_swap_reaches_every_goal_without_contact(swap):
    m = swap.metrics
    assert m["outcome"] == "success" and len(m["vehicles"]) == 3
    assert all(v["reached"] and not v["collided"] for v in m["vehicles"])
    assert 0.0 < m["min_separation"] < 2.0  # they met, and kept apart
    # The separation is each pair compared at both vehicles' logged times.
    flights = [swap, *swap.others]
    gaps = []
    for i, a in enumerate(flights):
        for b in flights[:i]:
            common = np.intersect1d(a.times, b.times)
            pa = a.positions[np.searchsorted(a.times, common)]
            pb = b.positions[np.searchsorted(b.times, common)]
            gaps.append(np.linalg.norm(pa - pb, axis=1).min())
    assert least_separation(flights) <= min(gaps) - 2 * swap.collision_radius + 1e-12


def test_a_fleets_log_holds_every_vehicle_and_its_line_the_fleets_outcome(
    swap, tmp_path
):
    path = str(tmp_path / "trajectory.npz")
    write_flight_log(path, swap)
    with np.load(path) as log:
        np.testing.assert_array_equal(log["state"], swap.log["state"])
        for k, other in enumerate(swap.others, 1):
            np.testing.assert_array_equal(log[f"vehicle{k}_times"], other.times)
            for name, logged in other.log.items():
                np.testing.assert_array_equal(log[f"vehicle{k}_{name}"], logged)
        assert f"vehicle{len(swap.others) + 1}_times" not in log
    sep = swap.metrics["min_separation"]
    line = summary_line(swap.metrics)
    assert (
        f"SUCCESS; fleet of 3: 3 reached, 0 collided, least separation {sep:.3f}"
        in line
    )
    assert "first vehicle: final error" in line


def _meeting(offset: float) -> sc.Scenario:
    """Two vehicles swapping the ends of a 6 m line, the second `offset` m
    to the side."""
    return sc.Scenario(
        name="meeting",
        start=[0.0, 0.0, 2.0],
        goal=[6.0, 0.0, 2.0],
        duration=10.0,
        other_vehicles=[OtherVehicle([6.0, offset, 2.0], [0.0, offset, 2.0])],
    )


def test_the_exchange_rate_moves_an_offset_meeting_by_little():
    # Two vehicles meeting nearly head-on, 0.4 m apart sideways: no symmetry
    # for rounding to break, so the flights must agree across rates.
    scene = _meeting(0.4)
    slow, fast = (
        simulate(dataclasses.replace(scene, exchange_hz=hz)).metrics for hz in (10, 40)
    )
    assert slow["outcome"] == fast["outcome"] == "success"
    # Flown straight they would touch (0.4 m < two radii): they swerved.
    assert 0.0 < slow["min_separation"] < 1.0
    assert slow["min_separation"] == pytest.approx(fast["min_separation"], abs=0.02)
    for a, b in zip(slow["vehicles"], fast["vehicles"], strict=True):
        assert a["path_length"] == pytest.approx(b["path_length"], abs=0.05)


def test_turned_right_is_the_clockwise_rotation_about_e_z():
    np.testing.assert_allclose(
        turned_right([1.0, 0.0, 0.5], 90.0), [0, -1, 0.5], atol=1e-15
    )
    w = np.array([0.3, -1.2, 0.7])
    turned = turned_right(w, 30.0)
    assert np.linalg.norm(turned) == pytest.approx(np.linalg.norm(w))
    heading = math.atan2(w[1], w[0]) - math.atan2(turned[1], turned[0])
    assert heading == pytest.approx(math.radians(30.0))


def _navigated(system, x, obstacle, u, vehicle=None):
    context = system.CreateDefaultContext()
    for name, value in (("state", x), ("obstacle", obstacle)):
        system.GetInputPort(name).FixValue(context, value)
    system.GetInputPort("obstacle_velocity").FixValue(context, u)
    if vehicle is not None:
        system.GetInputPort("vehicle_readings").FixValue(context, vehicle)
    return system.GetOutputPort("obstacle_force").Eval(context)


def test_the_rule_of_the_road_turns_only_the_vehicles_relative_velocity():
    """Second method: each reading's term is the plain navigator's with that
    reading alone and the state's velocity replaced by v − u, turned right
    for a vehicle (own pace off, so the terms simply add)."""
    params = sc.Scenario().navigator
    goal = [10.0, 0.0, 2.0]
    plain = MfiNavigator(params, goal, 0.225)
    ruled = RelativeNavigator(MfiNavigator(params, goal, 0.225), False, 0.3, 40.0)
    x = np.zeros(12)
    x[:3], x[6:9] = [1.0, 0.2, 2.0], [0.9, 0.1, 0.05]
    points = [[0.8, 0.3, 0.0], [0.2, -1.0, 0.1]]
    u = np.zeros(3 * 3)
    u[:3] = [-0.5, -0.2, 0.0]
    vehicle = np.array([1.0, 0.0, 0.0])  # the first reading is a vehicle
    got = _navigated(ruled, x, obstacle_signal(points), u, vehicle)
    want = np.zeros(3)
    for k, point in enumerate(points):
        y = x.copy()
        y[6:9] = x[6:9] - u[3 * k : 3 * k + 3]
        if vehicle[k]:
            y[6:9] = turned_right(y[6:9], 40.0)
        want += _navigated_plain(plain, y, obstacle_signal([point]))
    np.testing.assert_allclose(got, want, atol=1e-12)
    # The turn acted: without it the vehicle's term differs.
    unruled = RelativeNavigator(MfiNavigator(params, goal, 0.225), False, 0.3)
    assert np.abs(_navigated(unruled, x, obstacle_signal(points), u) - got).max() > 0.1


def _navigated_plain(system, x, obstacle):
    context = system.CreateDefaultContext()
    system.GetInputPort("state").FixValue(context, x)
    system.GetInputPort("obstacle").FixValue(context, obstacle)
    return system.GetOutputPort("obstacle_force").Eval(context)


def _sides(flown) -> list[float]:
    """Each vehicle's largest excursion to its right of the start–goal line
    (positive: it swerved right)."""
    sides = []
    for f in [flown, *flown.others]:
        start, goal = np.asarray(f.scenario.start), np.asarray(f.scenario.goal)
        line = (goal - start) / np.linalg.norm(goal - start)
        right = np.cross(line, [0.0, 0.0, 1.0])
        offsets = (f.positions - start) @ right
        sides.append(offsets[np.abs(offsets).argmax()])
    return sides


@pytest.mark.parametrize("keep_right, sign", [(30.0, 1.0), (0.0, -1.0)])
def test_vehicles_meeting_head_on_both_swerve_right_by_the_rule(keep_right, sign):
    # Without the rule both go left (the head-on tangent's bias e_z × n),
    # with it both go right: either way one side each, so they pass.
    scene = _meeting(0.0)
    rule = dataclasses.replace(scene.relative_velocity, keep_right=keep_right)
    flown = simulate(dataclasses.replace(scene, relative_velocity=rule))
    assert flown.metrics["outcome"] == "success"
    sides = _sides(flown)
    assert all(sign * side > 0.1 for side in sides), sides


# --- the sweep ----------------------------------------------------------------------
def _short(scenario: sc.Scenario) -> sc.Scenario:
    return dataclasses.replace(scenario, duration=1.0)


def test_fleet_sweep_records_every_vehicle(tmp_path, threads_client):
    config = fleet_sweep.FleetSweepConfig(
        n=1, seed=5, methods=["mfi", "gf"], vehicles=3, out=str(tmp_path)
    )
    config.variant = fleet_sweep.fleet_variant(3)
    run = sweep.run_sweep(
        config, threads_client, _short, sys.stdout, tasks=fleet_sweep.FLEET
    )
    assert (run.ran, run.lost) == (2, [])
    records = read_results(str(tmp_path / "results.jsonl"))
    for r in records:
        assert r["vehicles"] == 3 and len(r["path_ratios"]) == 3
        assert r["outcome"] == "timeout" and r["deadlocks"] == 3  # 1 s of 10 m
        assert len(r["reference_lengths"]) == 3
        assert r["min_separation"] > 0 and not r["vehicle_contact"]
    stats = run.summary["methods"]["mfi"]["0.1"]
    assert stats["n"] == 1 and stats["deadlock_fields"]["k"] == 1
    assert "| mfi | 0.1 | 1 |" in (tmp_path / "table.md").read_text()
    # Its figure draws where no vehicle succeeded (no path ratios).
    plot_fleet_sweep(run.summary, str(tmp_path / "sweep.png"))
    assert (tmp_path / "sweep.png").read_bytes().startswith(b"\x89PNG")


def test_sweep_rejects_a_fleet_of_none(tmp_path, capsys):
    assert main(["sweep", "--vehicles", "0", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--vehicles = 0" in err


def straight_at_the_goal(position, velocity, obstacle_points, goal):
    """A user field that pulls to the goal and ignores everything in the way."""
    return 1.5 * (np.asarray(goal) - position) - 2.0 * velocity


def test_a_fleet_stops_at_the_first_exchange_where_two_vehicles_touch():
    scene = _meeting(0.0)
    whole = simulate(scene, straight_at_the_goal)
    stopped = simulate(scene, straight_at_the_goal, stop_at_contact=True)
    assert whole.metrics["outcome"] == stopped.metrics["outcome"] == "collision"
    end = stopped.times[-1]
    assert end < 0.5 * whole.times[-1]
    assert end * scene.exchange_hz == pytest.approx(round(end * scene.exchange_hz))

    def gap(t):  # the centres' distance in the whole flight, at time t
        a, b = (
            [np.interp(t, f.times, f.positions[:, d]) for d in range(3)]
            for f in (whole, whole.others[0])
        )
        return math.dist(a, b)

    touching = 2 * whole.collision_radius
    assert gap(end) < touching <= gap(end - 1.0 / scene.exchange_hz)


def test_a_fleet_over_processes_flies_the_same_flights(swap):
    # Three vehicles over two processes (one in this, two in another): the
    # same integrators see the same exchanges, so the logs are identical.
    two = simulate(antipodal_circle(3, radius=3.0, duration=14.0), processes=2)
    for a, b in zip([swap, *swap.others], [two, *two.others], strict=True):
        np.testing.assert_array_equal(a.times, b.times)
        np.testing.assert_array_equal(a.log["state"], b.log["state"])
        assert scenario_to_yaml(a.scenario) == scenario_to_yaml(b.scenario)
    assert two.metrics == {
        **swap.metrics,
        "wall_time": two.metrics["wall_time"],
        "realtime_factor": two.metrics["realtime_factor"],
    }


def failing_field(position, velocity, obstacle_points, goal):
    raise ZeroDivisionError("on purpose")


def test_a_field_failing_in_another_process_fails_the_fleet_as_at_home():
    scene = dataclasses.replace(_meeting(0.4), duration=1.0)
    here = f"{__name__}:failing_field"
    errors = []
    for processes in (1, 2):
        with pytest.raises(Exception) as caught:
            simulate(scene, here, processes=processes)
        errors.append((type(caught.value), str(caught.value)))
    assert errors[0] == errors[1] and "on purpose" in errors[0][1]
