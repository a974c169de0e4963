"""mfi-nc in a fleet (docs/nonconvex.md, docs/fleets.md): each vehicle's
escape rule reads the static scene only; the other vehicles are moving
obstacles of MFI's field (eq 11–15, the relative velocity).

Oracles: the compiled fleet chain against each vehicle's single-vehicle
diagram of the systems engine at the same states and memories (the second
engine); the memories a compiled fleet built in flight against
`escape.update_memory` replayed along it with each vehicle's scene
readings (and not with the readings that hold the others); the goals
reached without contact in a room that MFI without the rule does not
leave."""

import dataclasses

import numpy as np
import pytest
from pydrake.systems.framework import EventStatus

from mfi_drake.config.navigation import navigation_config
from mfi_drake.config.scenario import OtherVehicle
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.builder import place_quadrotor
from mfi_drake.flight.diagram import build_diagram, vehicle_scenarios
from mfi_drake.flight.fleet import OneIntegratorFleet
from mfi_drake.flight.methods import escape_off, resolve_method
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.simulator import simulator_at_start
from mfi_drake.maths import escape, escape_steering, fields, fleet
from mfi_drake.maths.layout import POSITION, STATE_SIZE, VELOCITY
from mfi_drake.systems.exchange import message
from mfi_drake.systems.navigation import ObstacleNavigator
from mfi_drake.world.nonconvex import nonconvex_world, sealed_room
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS
from .test_one_integrator import VEHICLE, chain_arguments, crowded_fleet

RULE = escape.EscapeParams()
RADIUS = VEHICLE.collision_radius


def room_fleet(integration: str):
    """Two vehicles in the room of "room_exit" (seed 0, world 1), 1.2 m
    apart, their goals outside beyond the door: "mfi-memoryless" times out there
    (measured: neither reaches its goal in 90 s, one integrator)."""
    world = nonconvex_world("room_exit", 0, 1, duration=90.0)
    start = [world.start[0], world.start[1] + 1.2, world.start[2]]
    goal = [world.goal[0], world.goal[1] + 2.0, world.goal[2]]
    return dataclasses.replace(
        world,
        other_vehicles=[OtherVehicle(start=start, goal=goal)],
        fleet_integration=integration,
    )


def following(state: np.ndarray, goal) -> np.ndarray:
    """A memory that follows a surface from `state`'s position about +e_z,
    no surface seen yet: the subgoal is the followed reading's."""
    p = state[POSITION]
    memory = escape.initial_memory(p, np.asarray(goal, float))
    memory[escape.PHASE] = escape.FOLLOW
    memory[escape.HIT] = p
    memory[escape.D_HIT] = memory[escape.D_BEST]
    memory[escape.SIGN] = 1.0
    return memory


def test_the_chain_is_each_vehicles_escape_navigator_and_aims_by_the_scene():
    """Every vehicle following a surface: the fleet chain's row is, to the
    last bit, what the vehicle's single-vehicle diagram (EscapeNavigator's
    "scene", relative field) logs; the subgoal is aimed by the scene's
    readings, never by a vehicle's (given the readings with the others, the
    rule would follow one of them)."""
    scene, states = crowded_fleet()
    flown = vehicle_scenarios(scene)
    goals = np.array([s.goal for s in flown], float)
    memories = np.array([following(x, g) for x, g in zip(states, goals, strict=True)])
    modes = [fields.MODE_CRUISE] * 4
    want, readings, aims = [], [], []
    for k, one in enumerate(flown):
        flight = build_diagram(one, "mfi-nc")
        context = flight.diagram.CreateDefaultContext()
        flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(states[k])
        flight.diagram.GetInputPort("other_vehicles").FixValue(
            context, message(0.0, states[:, POSITION], states[:, VELOCITY], k)
        )
        for name, value in (("selector", [modes[k]]), ("navigator", memories[k])):
            system = flight.diagram.GetSubsystemByName(name)
            system_context = system.GetMyMutableContextFromRoot(context)
            system_context.get_mutable_discrete_state_vector().SetFromVector(value)
        out = []
        for name, port in (("log_mux", 0), ("scene_sensor", 0), ("navigator", 2)):
            system = flight.diagram.GetSubsystemByName(name)
            port = system.get_output_port(port)
            out.append(port.Eval(system.GetMyContextFromRoot(context)))
        want.append(out[0])
        readings.append(out[1])
        aims.append(out[2][1:])  # "escape": [phase, subgoal]
    want, readings = np.array(want), np.array(readings)
    arguments = list(chain_arguments(scene, states, readings, modes, False))
    rate = escape_steering.corner_rate(
        scene.navigator.K_v / VEHICLE.mass, scene.navigator.v_d, scene.navigator.r_b
    )
    arguments[-5:-1] = [memories, RULE, rate, escape.NO_GROUND]
    rows = np.zeros((len(states), fleet.ROW_SIZE))
    fleet.fleet_chain(*arguments, rows)
    np.testing.assert_array_equal(rows, want)

    merged = rows[:, fleet.row_slices()["obstacle"]]
    apart = []  # how far the subgoal would move, aimed by the merged readings
    for k in range(len(states)):
        p = states[k, POSITION]
        aim = escape_steering.subgoal(
            memories[k], p, readings[k], goals[k], RADIUS, RULE
        )
        np.testing.assert_array_equal(aims[k], aim)
        wrong = escape_steering.subgoal(
            memories[k], p, merged[k], goals[k], RADIUS, RULE
        )
        apart.append(np.linalg.norm(wrong - aim))
    assert max(apart) > 1.0


@pytest.mark.parametrize("integration", ["one", "separate"])
def test_two_vehicles_leave_a_room_by_its_door_without_contact(integration):
    """Both reach their goals, clear of the walls and of each other, on the
    compiled engine (one integrator) and the systems engine (exchange).
    Measured: success at 55.9 s (one) and 67.0 s (exchange); min
    separation 0.23 and 0.20 m."""
    metrics = simulate(room_fleet(integration), "mfi", until_settled=True).metrics
    assert metrics["outcome"] == "success"
    assert metrics["min_separation"] > 0.0
    for vehicle in metrics["vehicles"]:
        assert vehicle["reached"] and vehicle["min_clearance"] > 0.0


def recorded_room_flight(duration: float) -> list:
    """The compiled room fleet flown step by step: at its start and after
    every step, (t, states, each vehicle's scene readings, each one's
    merged readings, the memories)."""
    scenario = dataclasses.replace(room_fleet("one"), duration=duration)
    diagram = OneIntegratorFleet(scenario, "mfi-nc")
    simulator = simulator_at_start(diagram.diagram, diagram.plants[0], scenario)
    root = simulator.get_mutable_context()
    place_quadrotor(diagram.plants[1], root, diagram.flown[1].start)
    chain, sensor = diagram.chain, diagram.scene_sensor
    n, records = len(diagram.flown), []

    def record(context):
        here = chain.GetMyContextFromRoot(context)
        rows = chain.GetOutputPort("rows").Eval(here).reshape(n, fleet.ROW_SIZE)
        scene = sensor.GetOutputPort("scene").Eval(sensor.GetMyContextFromRoot(context))
        states = chain.GetInputPort("states").Eval(here).reshape(n, STATE_SIZE)
        merged = rows[:, fleet.row_slices()["obstacle"]]
        records.append(
            (
                context.get_time(),
                states,
                scene.reshape(n, -1),
                merged,
                chain.memories(here),
            )
        )
        return EventStatus.Succeeded()

    simulator.set_monitor(record)
    simulator.AdvanceTo(duration)
    return records


def test_each_memory_is_the_rule_replayed_on_its_scene_readings_alone():
    """Along a compiled fleet's flight out of the room, each vehicle's
    memory after every step equals `update_memory` of the memory before it
    at the state and scene readings where the step began (to the last bit:
    the clones equal the Python rule), through FOLLOW and PASS; the readings
    with the other vehicle would have built another memory (measured: at
    175 of 10,180 steps)."""
    records = recorded_room_flight(56.0)
    phases, differs = set(), 0
    goals = [np.array(s.goal, float) for s in vehicle_scenarios(room_fleet("one"))]
    for (t, states, scene, merged, before), (*_, after) in zip(
        records[:-1], records[1:], strict=True
    ):
        for k, x in enumerate(states):
            want = escape.update_memory(
                before[k],
                t,
                x[POSITION],
                x[VELOCITY],
                scene[k],
                goals[k],
                RADIUS,
                RULE,
                0.0,
            )
            np.testing.assert_array_equal(after[k], want)
            other = escape.update_memory(
                before[k],
                t,
                x[POSITION],
                x[VELOCITY],
                merged[k],
                goals[k],
                RADIUS,
                RULE,
                0.0,
            )
            differs += not np.array_equal(other, want)
            phases.add(int(want[escape.PHASE]))
    assert {escape.FOLLOW, escape.PASS} <= phases
    assert differs > 0


def test_a_trapped_vehicle_ends_a_compiled_fleet_and_is_named():
    """A goal in a doorless room (`sealed_room`) with a second vehicle
    flying elsewhere, on one integrator: the rule of the first runs out of
    options, which ends the fleet's flight (as exchange ends it): outcome
    "trapped", the first vehicle's entry "trapped", the second's not, no
    contact. The lone vehicle ends trapped at 117 s
    (tests/test_escape_compiled.py)."""
    world = sealed_room(0, 0)
    other = OtherVehicle(start=[0.0, -3.0, world.start[2]], goal=[0.0, -6.0, 2.0])
    fleet_world = dataclasses.replace(
        world, other_vehicles=[other], fleet_integration="one", duration=150.0
    )
    flight = simulate(fleet_world, "mfi-nc")
    metrics = flight.metrics
    assert metrics["outcome"] == "trapped"
    assert [v.get("trapped", False) for v in metrics["vehicles"]] == [True, False]
    assert metrics["vehicles"][1]["reached"]
    assert metrics["min_separation"] > 0.0
    assert all(v["min_clearance"] > 0.0 for v in metrics["vehicles"])
    assert flight.times[-1] < fleet_world.duration


@pytest.mark.parametrize(
    "name, integration",
    [
        ("swarm_circle", "one"),
        ("swarm_corridor", "one"),
        ("swarm_corridor", "separate"),
    ],
)
def test_the_swarms_fly_as_mfi_flies_them(name, integration):
    """In the shipped swarms nothing traps and no corner of the scene (the
    ground alone) brakes: the rule leaves MFI's relative field as it is,
    so mfi flies mfi-memoryless's flight to the last bit on both engines."""
    scene = dataclasses.replace(
        load_scenario(f"{SCENARIOS}/{name}.yaml"), fleet_integration=integration
    )
    want, got = simulate(scene, "mfi-memoryless"), simulate(scene, "mfi")
    assert got.metrics["outcome"] == want.metrics["outcome"] == "success"
    for a, b in zip([want, *want.others], [got, *got.others], strict=True):
        np.testing.assert_array_equal(b.times, a.times)
        np.testing.assert_array_equal(b.log["state"], a.log["state"])


@pytest.mark.parametrize(
    "scene, change, why",
    [
        ("swarm_corridor", "sensor: !DepthCamera {}", "a fleet with cameras"),
        ("planar_wall", "sensor: !DepthCamera {}", "cameras (escape.cameras: false)"),
        (
            "moving_crossing",
            "other_vehicles: [{start: [0, 3, 2], goal: [9, 3, 2]}]",
            "obstacles move",
        ),
        ("moving_crossing", None, "obstacles move"),
    ],
)
def test_mfi_flies_memoryless_where_no_static_scene_can_be_told(scene, change, why):
    """Where the readings hold no static scene the memory could remember
    (cameras render the other vehicles into it; moving obstacles), MFI and
    its alias mfi-nc fly MFI's memoryless navigator, as mfi-memoryless."""
    layers = [("change", change)] if change else []
    scenario = load_scenario(f"{SCENARIOS}/{scene}.yaml", layers)
    config = navigation_config(scenario)
    assert escape_off(config) == why
    for name in ("mfi", "mfi-nc", "mfi-memoryless"):
        navigator = resolve_method(name).navigator(config, VEHICLES[scenario.vehicle])
        assert isinstance(navigator, ObstacleNavigator)  # not EscapeNavigator
        assert navigator.field is fields.obstacle_field


def test_a_lone_mfi_among_moving_obstacles_is_mfi_memoryless_to_the_bit():
    """Oracle: the memoryless method's flight (issue 38's default MFI may not
    change what it cannot improve)."""
    scene = load_scenario(f"{SCENARIOS}/moving_crossing.yaml")
    want, got = simulate(scene, "mfi-memoryless"), simulate(scene, "mfi")
    np.testing.assert_array_equal(got.positions, want.positions)
    assert got.metrics["min_clearance"] == want.metrics["min_clearance"]
