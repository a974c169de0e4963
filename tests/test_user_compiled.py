"""A user's field on the compiled engine (docs/usage.md, "Your own field"):
a field numba compiles flies compiled, alone and in a fleet on one
integrator, with its gains; any other flies on `systems` with one line
saying why, or is refused by name where there is no `systems` form (a
fleet on one integrator). Oracles: the systems engine's
`UserFieldNavigator` (the same Python function, called by Python), and a
fleet too far apart to read each other against its vehicles flown alone."""

import dataclasses
import logging

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.flight.fleet import check_engine, unsupported
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import fleet
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE, STATE_SIZE
from mfi_drake.systems.fleet import UserForces
from mfi_drake.systems.relative import VELOCITY_SIGNAL_SIZE
from mfi_drake.systems.user_field import UserFieldError, UserFieldNavigator, call_field
from mfi_drake.world.fleets import with_vehicles
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

WALL = f"{SCENARIOS}/planar_wall.yaml"


# Written as a user would, self-contained (numba compiles what a field
# calls only where that is numba's or numpy's).
def around(position, velocity, obstacle_points, goal, k=1.5, push=0.5):
    to_goal = goal - position
    force = k * to_goal / max(np.linalg.norm(to_goal), 1.0) - 2.0 * velocity
    for r in obstacle_points:  # away from each reading, and round it to the left
        force -= push * (r + np.cross(r, np.array([0.0, 0.0, 1.0])))
        force /= 1.0 + max(np.linalg.norm(r), 0.05) ** -3
    return force


def as_tuple(position, velocity, obstacle_points, goal):
    pull = goal - position - 2.0 * velocity
    return (pull[0], pull[1], pull[2] + 0.1 * len(obstacle_points))


def fails_past_one_metre(position, velocity, obstacle_points, goal):
    if position[0] > 1.0:
        raise ValueError("too far")
    return goal - position - 2.0 * velocity


def nan_past_one_metre(position, velocity, obstacle_points, goal):
    if position[0] > 1.0:
        return np.array([np.nan, 0.0, 0.0])
    return goal - position - 2.0 * velocity


def spring(offset, velocity):
    return offset - 2.0 * velocity


def with_a_helper(position, velocity, obstacle_points, goal):
    return spring(goal - position, velocity)  # not numba's: it cannot call it


def wall(duration: float, engine: str, **changes):
    scenario = load_scenario(WALL)
    return dataclasses.replace(scenario, duration=duration, engine=engine, **changes)


@pytest.mark.parametrize(
    "field, gains",
    [(around, {}), (around, {"push": 0.8, "k": 1.2}), (as_tuple, {})],
)
def test_a_compiled_field_flies_the_systems_flight(field, gains):
    systems = simulate(wall(12.0, "systems", field_gains=gains), field)
    fast = simulate(wall(12.0, "compiled", field_gains=gains), field)
    assert (systems.metrics["engine"], fast.metrics["engine"]) == (
        "systems",
        "compiled",
    )
    assert fast.metrics["outcome"] == systems.metrics["outcome"]
    assert (fast.log["obstacle"][:, 3] > 0.5).any()  # the wall was read
    # numba's norm and cross differ from numpy's in last bits: the same
    # steps, not to the bit.
    np.testing.assert_allclose(fast.times, systems.times, rtol=0, atol=1e-9)
    for key in ("state", "obstacle", "navigation_force", "mode", "propeller_force"):
        np.testing.assert_allclose(
            fast.log[key], systems.log[key], rtol=0, atol=1e-9, err_msg=key
        )


def test_its_forces_are_the_python_calls_at_random_fleet_states():
    """Eight vehicles near each other among scene readings: `UserForces`
    against `call_field` at each vehicle's readings (`readings_of`)."""
    rng = np.random.default_rng(7)
    n = 8
    navigator = UserFieldNavigator(around, "around", [0.0, 0.0, 0.0], {"push": 0.7})
    forces = UserForces(navigator, n, 0.2, 3.0)
    for _ in range(20):
        states = rng.normal(scale=1.5, size=(n, STATE_SIZE))
        scene = rng.normal(size=(n, OBSTACLE_SIGNAL_SIZE))
        scene[:, 3::4] = rng.integers(0, 2, size=(n, 3))  # seen or not
        u = np.zeros((n, VELOCITY_SIGNAL_SIZE))
        goals = rng.normal(scale=5.0, size=(n, 3))
        got = forces(states, scene, u, goals, 0.0)
        for k in range(n):
            readings = fleet.readings_of(k, states, scene, u, 0.2, 3.0)
            expected = call_field(
                around, "around", {"push": 0.7}, goals[k], states[k], readings, 0.0
            )
            np.testing.assert_allclose(got[k], expected, rtol=1e-12, atol=1e-12)


def test_a_far_apart_fleet_flies_each_vehicle_as_alone():
    alone = wall(8.0, "compiled")
    far = [float(alone.start[0]), float(alone.start[1]) + 30.0, float(alone.start[2])]
    far_goal = [float(alone.goal[0]), far[1], float(alone.goal[2])]
    pairs = [(alone.start, alone.goal), (far, far_goal)]
    flown = simulate(
        dataclasses.replace(with_vehicles(alone, pairs), fleet_integration="one"),
        around,
    )
    assert flown.metrics["engine"] == "compiled"
    first = simulate(alone, around)
    second = simulate(dataclasses.replace(alone, start=far, goal=far_goal), around)
    # The integrator's steps are the fleet's (its error is both vehicles'):
    # the same paths within the error it controls, not to the bit.
    for vehicle, lone in ((flown, first), (flown.others[0], second)):
        assert vehicle.metrics["outcome"] == lone.metrics["outcome"]
        end = vehicle.positions[-1] - lone.positions[-1]
        assert np.linalg.norm(end) < 1e-3


def test_a_fleet_of_fields_reads_each_other():
    """Two vehicles head on, one field that counts its readings in F_n's z:
    each climbs once the other is within reach (3 m), and not before."""
    scenario = wall(4.0, "compiled", obstacles=[])
    pairs = [([0.0, 0.0, 1.0], [6.0, 0.0, 1.0]), ([6.0, 0.0, 1.0], [0.0, 0.0, 1.0])]
    fleet_scenario = dataclasses.replace(
        with_vehicles(scenario, pairs), fleet_integration="one"
    )
    flown = simulate(fleet_scenario, as_tuple)
    seen = flown.log["obstacle"][:, 3] > 0.5
    assert not seen[0] and seen.any()
    climbing = flown.log["navigation_force"][:, 2]
    pull = -(flown.positions[:, 2] - 1.0) - 2.0 * flown.log["state"][:, 8]
    np.testing.assert_allclose(climbing, pull + 0.1 * seen, atol=1e-12)


@pytest.mark.parametrize(
    "field, says",
    [
        (fails_past_one_metre, "raised ValueError: too far"),
        (nan_past_one_metre, "returned [nan, 0.0, 0.0]: must be 3 finite"),
    ],
)
def test_a_failing_compiled_field_says_what_systems_says(field, says):
    with pytest.raises(UserFieldError) as compiled_error:
        simulate(wall(5.0, "compiled"), field)
    with pytest.raises(UserFieldError) as systems_error:
        simulate(wall(5.0, "systems"), field)
    assert str(compiled_error.value) == str(systems_error.value)
    assert says in str(compiled_error.value)


def test_a_field_numba_cannot_compile_flies_on_systems_saying_why(caplog):
    assert unsupported(wall(1.0, "compiled"), with_a_helper) is not None
    with caplog.at_level(logging.WARNING, logger="mfi_drake"):
        flight = simulate(wall(1.0, "compiled"), with_a_helper)
    assert flight.metrics["engine"] == "systems"
    (line,) = caplog.messages
    assert "engine: systems (method " in line and "numba cannot compile" in line
    assert "Untyped global name 'spring'" in line and "test_user_compiled.py" in line
    assert "\n" not in line
    # A fleet on one integrator has no systems form: refused by name.
    pairs = [([0.0, 0.0, 1.0], [6.0, 0.0, 1.0]), ([6.0, 3.0, 1.0], [0.0, 3.0, 1.0])]
    fleet_scenario = dataclasses.replace(
        with_vehicles(wall(1.0, "systems"), pairs), fleet_integration="one"
    )
    with pytest.raises(ScenarioError, match="numba cannot compile the field"):
        check_engine(fleet_scenario, [with_a_helper])


def test_run_says_the_engine_that_flew(tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    (tmp_path / "mine.py").write_text(
        "def pull(position, velocity, obstacle_points, goal):\n"
        "    return goal - position - 2.0 * velocity\n"
    )
    out = tmp_path / "out"
    args = ["run", WALL, "--method", "mine:pull", "--out", str(out), "--json"]
    main([*args, "--set", "{engine: compiled, duration: 1.0}"])
    assert '"engine": "compiled"' in capsys.readouterr().out
    # numba keeps the field's machine code beside its file, for later processes.
    assert list((tmp_path / "__pycache__").glob("mine.pull-*.nbi"))
