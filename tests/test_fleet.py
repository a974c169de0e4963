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
from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Motion, OtherVehicle
from mfi_drake.flight.diagram import vehicle_scenarios
from mfi_drake.flight.simulation import least_separation, simulate
from mfi_drake.maths.layout import obstacle_signal, readings
from mfi_drake.studies import fleet_sweep, sweep
from mfi_drake.systems.exchange import extrapolated, merge, message
from mfi_drake.world import generator
from mfi_drake.world.fleets import (
    PAIR_GAP,
    antipodal_circle,
    crossing_streams,
    random_pairs,
)
from mfi_drake.world.obstacles import nearest_obstacles, sensed
from mfi_drake.world.validation import ScenarioWarning, validate_scenario


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
    signal, u = merge(np.zeros(3), scene, received, 0.5, 0.2, 3.0)
    (first, seen_1), (second, seen_2), (_, seen_3) = readings(signal)
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
    signal, u = merge(np.zeros(3), scene, received, 0.0, 0.2, 3.0)
    assert signal is scene and not u.any()


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
    records = sweep.read_results(str(tmp_path / "results.jsonl"))
    for r in records:
        assert r["vehicles"] == 3 and len(r["path_ratios"]) == 3
        assert r["outcome"] == "timeout" and r["deadlocks"] == 3  # 1 s of 10 m
        assert len(r["reference_lengths"]) == 3
        assert r["min_separation"] > 0 and not r["vehicle_contact"]
    stats = run.summary["methods"]["mfi"]["0.1"]
    assert stats["n"] == 1 and stats["deadlock_fields"]["k"] == 1
    assert "| mfi | 0.1 | 1 |" in (tmp_path / "table.md").read_text()


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
