"""mfi-nc on the compiled engine (issues 38, 40; docs/nonconvex.md "The
escape rule"): the escape rule compiled by `maths.compiled` equals
`maths.escape`'s, and whole flights on the two engines are the same flight.

The second method is the oracle: the Python functions that the systems
engine's `EscapeNavigator` calls, against their numba clones, at the
memories of real flights (a door passed, a cup, a sealed room ending
TRAPPED), rebuilt by replaying the rule along the compiled flights' logs."""

import dataclasses
import functools

import numpy as np
import pytest

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import OtherVehicle
from mfi_drake.config.sensors import DepthCamera
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.fleet import unsupported
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import compiled, escape, escape_steering, fields
from mfi_drake.maths.layout import POSITION, VELOCITY
from mfi_drake.world.nonconvex import nonconvex_world, sealed_room

from .test_escape import RADIUS, RULE

# (world, outcome): through a door of a room (FOLLOW, then PASS), out of
# a cup, and round a doorless room round the goal until every axis is
# exhausted (TRAPPED at ~117 s).
WORLDS = {
    "door": (nonconvex_world("room_exit", 0, 1, duration=60.0), "success"),
    "cup": (nonconvex_world("cup", 0, 0, duration=60.0), "success"),
    "sealed": (sealed_room(0, 0), "trapped"),
}


@functools.cache
def flown(name: str, engine: str):
    world = dataclasses.replace(WORLDS[name][0], engine=engine, duration=150.0)
    if name != "sealed":
        world = dataclasses.replace(world, duration=60.0)
    return simulate(world, "mfi")


@pytest.mark.parametrize("name", list(WORLDS))
def test_mfi_nc_flies_the_same_flight_on_both_engines(name):
    """The same outcome, the same steps and positions within 1e-6 m at the
    same logged times (measured: equal to the last bit)."""
    systems, fast = flown(name, "systems"), flown(name, "compiled")
    assert fast.metrics["engine"] == "compiled"
    assert systems.metrics["engine"] == "systems"
    assert fast.metrics["outcome"] == systems.metrics["outcome"] == WORLDS[name][1]
    np.testing.assert_array_equal(fast.times, systems.times)
    assert np.abs(fast.positions - systems.positions).max() <= 1e-6


def test_a_goal_in_a_sealed_room_on_the_ground_ends_trapped():
    """A doorless room on the ground round the goal (`sealed_room`): the
    rule goes round it, over it, never under it nor along the ground, and
    ends trapped without contact, never farther from the goal than the
    start. (Following the ground on the horizontal axes it flew 305 m away
    in 400 s.) The compiled flight: the systems engine's is the same
    (above)."""
    flight, world = flown("sealed", "compiled"), WORLDS["sealed"][0]
    assert flight.metrics["outcome"] == "trapped"
    assert flight.metrics["min_clearance"] > 0.0
    away = np.linalg.norm(flight.log["state"][:, :3] - world.goal, axis=1)
    assert away.max() <= np.linalg.norm(np.subtract(world.start, world.goal)) + 1e-9


def test_the_compiled_rule_equals_the_python_rule_at_real_memories():
    """At every logged step of the door's and the sealed room's compiled
    flights, with the memory the rule builds along the log: the compiled
    `update_memory` equals the Python one exactly, and `escape_terms`
    (A, B, the subgoal) within 1e-12; FOLLOW, PASS and TRAPPED are met."""
    clones = compiled.compiled(escape)
    rule, navigator = compiled.record(RULE), NavigatorParams()
    rate = escape_steering.corner_rate(
        navigator.K_v / VEHICLES["drake_default"].mass, navigator.v_d, navigator.r_b
    )
    field = compiled.compiled_form(fields.obstacle_field)
    phases, worst = set(), 0.0
    for name in ("door", "sealed"):
        flight = flown(name, "compiled")
        world = WORLDS[name][0]
        goal = np.array(world.goal, float)
        ground = world.ground.height
        states, readings = flight.log["state"], flight.log["obstacle"]
        memory = escape.initial_memory(states[0, POSITION].copy(), goal)
        for t, x, obstacle in zip(flight.times, states, readings, strict=True):
            p, v = x[POSITION].copy(), x[VELOCITY].copy()
            obstacle = obstacle.copy()
            new = escape.update_memory(
                memory, t, p, v, obstacle, goal, RADIUS, RULE, ground
            )
            again = clones.update_memory(
                memory, t, p, v, obstacle, goal, RADIUS, rule, ground
            )
            np.testing.assert_array_equal(again, new)
            memory = new
            phases.add(int(memory[escape.PHASE]))
            want = escape_steering.escape_terms(
                fields.obstacle_field,
                memory,
                p,
                v,
                obstacle,
                obstacle,
                goal,
                RADIUS,
                navigator,
                RULE,
                rate,
                ground,
            )
            got = compiled.compiled(escape_steering).escape_terms(
                field,
                memory,
                p,
                v,
                obstacle,
                obstacle,
                goal,
                RADIUS,
                compiled.record(navigator),
                rule,
                rate,
                ground,
            )
            for a, b in zip(got, want, strict=True):
                worst = max(worst, float(np.abs(a - b).max()))
    assert {escape.FOLLOW, escape.PASS, escape.TRAPPED} <= phases
    assert worst <= 1e-12


def test_a_fleet_of_mfi_nc_flies_compiled_but_not_with_cameras():
    """One integrator flies a fleet of mfi-nc (a memory a vehicle,
    tests/test_escape_fleet.py); with cameras the others cannot be told from
    the scene (MFI flies memoryless, `methods.escape_off`) and the compiled
    chain reads no camera: refused, naming the sensor."""
    world = WORLDS["door"][0]
    assert unsupported(dataclasses.replace(world, engine="compiled"), "mfi-nc") is None
    other = dataclasses.replace(
        world,
        other_vehicles=[OtherVehicle(start=[0.0, 3.0, 1.5], goal=[9.0, 3.0, 1.5])],
    )
    assert unsupported(other, "mfi-nc") is None
    cameras = dataclasses.replace(other, sensor=DepthCamera())
    assert unsupported(cameras, "mfi-nc") == (
        "sensor: the compiled chain flies the sphere sensor only"
    )
