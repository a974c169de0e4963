"""`NavigationStep`, the navigation chain one call at a time: it equals the
diagram's logged outputs at the logged inputs along flights of every
method, reads obstacle points as the sphere sensor reads SceneGraph,
switches eq 21's mode by its guards, takes the vehicle and parameter
overrides, and refuses bad arguments in one line (examples/step_loop.py,
the step in a plain loop, is run by tests/test_examples.py)."""

import dataclasses
import os

import numpy as np
import pytest
from pydrake.geometry import GeometryInstance, RenderLabel, Rgba, SceneGraph, Sphere
from pydrake.math import RigidTransform

from mfi_drake import NavigationStep, load_scenario, simulate
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.methods import MethodError
from mfi_drake.maths import escape, fields
from mfi_drake.maths.layout import (
    OBSTACLE_COUNT,
    POSITION,
    obstacle_signal,
    point_readings,
    seen_points,
)
from mfi_drake.world.nonconvex import nonconvex_world
from mfi_drake.world.obstacles import nearest_obstacles, sensed

from .conftest import SCENARIOS

OUTPUTS = ("navigation_force", "attitude_setpoint", "propeller_force")
TOLERANCE = 1e-12  # the points come back as p + r_o: r_o loses the last bits


def pull_and_push(position, velocity, obstacle_points, goal):
    """A user's field: toward the goal, away from what is seen."""
    pull = 1.5 * (goal - position) - 2.0 * velocity
    pull *= min(1.0, 3.0 / max(np.linalg.norm(pull), 1e-9))
    push = sum((-p / np.linalg.norm(p) ** 3 for p in obstacle_points), np.zeros(3))
    return pull + 0.3 * push


@pytest.mark.parametrize(
    "scene, method",
    [
        ("planar_wall", "mfi"),
        ("planar_wall", "mfi-paper"),
        ("planar_wall", "apf"),
        ("planar_wall", "gf"),
        ("planar_wall", pull_and_push),
        ("three_spheres", "mfi"),
        ("tree", "mfi"),
    ],
)
def test_the_step_equals_the_logged_diagram_at_the_logged_inputs(scene, method):
    # Oracle: the diagram's own log. Each logged state and reading (as world
    # points p + r_o) goes through the step in order; its outputs must be
    # the logged ones. The mode differs only at the end of a step that the
    # simulator's witness isolation cut at a guard's crossing: the log holds
    # the mode the step flew in, the switch follows at the next step's start.
    scenario = load_scenario(os.path.join(SCENARIOS, f"{scene}.yaml"))
    scenario = dataclasses.replace(scenario, duration=15.0)
    flight = simulate(scenario, method, until_settled=True)
    log, times = flight.log, flight.times
    step = NavigationStep.from_scenario(scenario, method)
    modes = np.round(log["mode"][:, 0]).astype(int)
    window = scenario.simulator.accuracy  # [s] where witness isolation stops
    mismatched, worst, previous = [], dict.fromkeys(OUTPUTS, 0.0), None
    for k, x in enumerate(log["state"]):
        points = x[POSITION] + seen_points(log["obstacle"][k])
        out = step.step(x, points, times[k])
        np.testing.assert_allclose(out.obstacle, log["obstacle"][k], 0, TOLERANCE)
        if out.mode != modes[k]:
            # The logged step was cut short at the crossing, flown in the
            # mode before; the log switches at its next step.
            assert modes[k] == previous and modes[k + 1] == out.mode
            assert times[k] - times[k - 1] <= window
            mismatched.append(k)
        else:
            F_o = log["obstacle_force_terms"][k]
            np.testing.assert_allclose(out.obstacle_force, F_o[:3] + F_o[3:], 0, 1e-12)
            for name in OUTPUTS:
                worst[name] = max(
                    worst[name], np.max(np.abs(getattr(out, name) - log[name][k]))
                )
        previous = out.mode
    assert max(worst.values()) <= TOLERANCE, worst
    # The last logged step of each mode: one mismatch a switch, at its instant.
    assert mismatched == list(np.flatnonzero(np.diff(modes)))
    if method in ("mfi", "mfi-paper"):  # cruise and back to PD at the goal
        assert len(mismatched) == 2
    assert len(mismatched) <= 2 and len(times) > 500


def test_the_step_carries_the_escape_memory_as_the_diagram_does():
    """The default mfi out of a cup (TOWARD, FOLLOW, PASS). Oracle: the diagram's
    log. Its row k holds the outputs at the state x_k with the memory as it
    was before the update at t_k (the logger publishes at the end of the
    step before): where the update changes the phase, the logged force is
    the navigator's at the previous call's memory, and the step's, the one
    flown from t_k on, follows in row k + 1; elsewhere they are equal."""
    world = nonconvex_world("cup", 0, 0, duration=40.0)
    flight = simulate(dataclasses.replace(world, engine="compiled"), "mfi")
    assert flight.metrics["outcome"] == "success"
    log, times = flight.log, flight.times
    step = NavigationStep.from_scenario(world, "mfi")
    assert step.memory is None  # before the first call
    navigator = step._chain[0]
    changed, mismatched, phases, before = [], [], set(), None
    for k, x in enumerate(log["state"]):
        points = x[POSITION] + seen_points(log["obstacle"][k])
        out = step.step(x, points, times[k])
        phases.add(int(out.escape[0]))
        logged = log["obstacle_force_terms"][k]
        if np.abs(out.obstacle_force - logged[:3] - logged[3:]).max() > 1e-12:
            mismatched.append(k)
            cruise = out.mode == fields.MODE_CRUISE
            at_before = navigator.terms_of(x, out.obstacle, before, cruise)[2]
            np.testing.assert_allclose(at_before, logged[:3] + logged[3:], 0, 1e-12)
        if before is not None and step.memory[escape.PHASE] != before[escape.PHASE]:
            changed.append(k)
        before = step.memory
    assert phases == {escape.TOWARD, escape.FOLLOW, escape.PASS}
    assert mismatched == changed and len(changed) >= 3
    with pytest.raises(ValueError, match=r"NavigationStep: t = 1\.0: must not go back"):
        step.step(log["state"][-1], np.zeros((0, 3)), 1.0)
    step.reset()
    assert step.memory is None


def test_points_are_read_as_the_sphere_sensor_reads_scene_graph():
    # Oracle: SceneGraph's sphere sensor reading of random spheres, against
    # the readings of their closest points (more spheres than readings,
    # some out of range), seen from outside them all (points cannot say
    # that the vehicle's centre is inside an obstacle).
    rng = np.random.default_rng(0)
    scene_graph = SceneGraph()
    source = scene_graph.RegisterSource("spheres")
    centres, radii = rng.uniform(-4, 4, (9, 3)), rng.uniform(0.2, 1.0, 9)
    for i, (c, r) in enumerate(zip(centres, radii, strict=True)):
        instance = GeometryInstance(RigidTransform(c), Sphere(r), f"s{i}")
        sensed(instance, Rgba(1, 1, 1, 1), RenderLabel(i + 1))
        scene_graph.RegisterAnchoredGeometry(source, instance)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    seen = 0
    for p in rng.uniform(-3, 3, (40, 3)):
        away = p - centres
        gaps = np.linalg.norm(away, axis=1)
        if np.any(gaps <= radii):
            continue
        seen += 1
        points = centres + radii[:, None] * away / gaps[:, None]
        expected = nearest_obstacles(query, p, 2.5)
        np.testing.assert_allclose(point_readings(p, points, 2.5), expected, 0, 1e-12)
    assert seen >= 20


def test_the_nearest_three_within_the_radius_are_read_nearest_first():
    # Hand-computed: five points around p, one beyond r_s = 3, one on it.
    p = np.array([1.0, 1.0, 1.0])
    offsets = [[0, 0, 2.5], [0, 3.0, 0], [1.0, 0, 0], [0, -3.5, 0], [2.0, 0, 0]]
    readings = point_readings(p, p + np.array(offsets, float), 3.0)
    assert OBSTACLE_COUNT == 3
    np.testing.assert_array_equal(
        readings, obstacle_signal([offsets[i] for i in (2, 4, 0)])
    )
    none = point_readings(p, np.zeros((0, 3)), 3.0)
    np.testing.assert_array_equal(none, np.zeros_like(readings))
    step = NavigationStep([5.0, 1.0, 1.0])
    x = np.concatenate([p, np.zeros(9)])
    assert np.all(step.step(x, []).obstacle == 0.0)
    on_the_sphere = step.step(x, [[1.0, 4.0, 1.0]]).obstacle  # |r_o| = r_s
    np.testing.assert_array_equal(on_the_sphere, obstacle_signal([[0, 3.0, 0]]))


def _state(p, v) -> np.ndarray:
    return np.concatenate([p, np.zeros(3), v, np.zeros(3)])


def test_the_mode_switches_with_the_guards_hysteresis_and_restarts_on_reset():
    # Hand oracle from eq 21's thresholds: PD → cruise at |v| ≥ v_min (far
    # from the goal), cruise → PD only below v_stop.
    params = NavigatorParams()
    goal = np.array([10.0, 0.0, 1.5])
    step = NavigationStep(goal)
    p = np.array([0.0, 0.0, 1.5])
    between = 0.5 * (params.v_stop + params.v_min)
    expected = [
        (0.0, fields.MODE_PD),
        (between, fields.MODE_PD),  # not yet v_min
        (params.v_min, fields.MODE_CRUISE),  # the guard reaches 0
        (between, fields.MODE_CRUISE),  # hysteresis: held above v_stop
        (0.5 * params.v_stop, fields.MODE_PD),
    ]
    assert step.mode is None
    for speed, mode in expected:
        assert step.step(_state(p, [speed, 0.0, 0.0]), []).mode == mode
        assert step.mode == mode
    step.step(_state(p, [1.0, 0.0, 0.0]), [])
    step.reset()  # from scratch: cruise only above v_min, as the diagram starts
    assert step.step(_state(p, [between, 0.0, 0.0]), []).mode == fields.MODE_PD
    # In cruise F_n holds eq 19's speed control, in PD eq 20's.
    near = NavigationStep(goal, navigator={"K_P": 2.0, "K_D": 1.0})
    F_n = near.step(
        _state(goal - [0.5, 0.0, 0.0], [0.1, 0.0, 0.0]), []
    ).navigation_force
    np.testing.assert_allclose(F_n, [2.0 * 0.5 - 0.1, 0.0, 0.0], 0, 1e-15)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_a_vehicle_hovering_at_its_goal_gets_its_hover_command(vehicle):
    goal = np.array([1.0, 2.0, 3.0])
    out = NavigationStep(goal, vehicle=vehicle).step(_state(goal, np.zeros(3)), [])
    hover = VEHICLES[vehicle].hover_command
    np.testing.assert_allclose(out.propeller_force, [hover] * 4, 1e-12)
    np.testing.assert_allclose(out.thrust, VEHICLES[vehicle].weight, 1e-12)
    assert np.all(out.navigation_force == 0.0) and out.mode == fields.MODE_PD


@pytest.mark.parametrize(
    "arguments, call, says",
    [
        ({"method": "nope"}, None, "'nope': must be one of"),
        ({"vehicle": "blimp"}, None, "vehicle = 'blimp': must be one of"),
        ({"goal": [1.0, 2.0]}, None, "goal = [1.0, 2.0]: must be [x, y, z]"),
        ({"goal": [1.0, np.nan, 2.0]}, None, "goal = "),
        ({"navigator": {"c": -1.0}}, None, "navigator.c = -1.0: must be > 0"),
        ({"navigator": {"speed": 1.0}}, None, "navigator.speed = 1.0: no such"),
        ({"sensor_radius": 0.0}, None, "sensor.radius = 0.0: must be a finite"),
        ({}, (np.zeros(9), []), "state = array("),
        ({}, (np.full(12, np.nan), []), "state = array([nan,"),
        (
            {},
            (np.zeros(12), [1.0, 2.0, 3.0]),
            "points = [1.0, 2.0, 3.0]: must be k × 3",
        ),
        (
            {},
            (np.zeros(12), [[1.0, np.inf, 3.0]]),
            "points = [[1.0, inf, 3.0]]: must hold finite",
        ),
    ],
)
def test_a_bad_argument_is_one_line_naming_it(arguments, call, says):
    with pytest.raises((ValueError, MethodError)) as error:
        step = NavigationStep(**({"goal": [5.0, 0.0, 1.5]} | arguments))
        step.step(*call)
    message = str(error.value)
    assert says in message and "\n" not in message
