"""A fleet on one integrator (`flight.fleet`, `fleet_integration: one`): its
chain against the single-vehicle diagrams it stands for, the compiled chain
against the Python one, physical invariants, flights against separate
integration, and the refusals."""

import dataclasses

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import LOG_LAYOUT, build_diagram, vehicle_scenarios
from mfi_drake.flight.fleet import OneIntegratorFleet, check_engine
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import compiled, escape, fields, fleet
from mfi_drake.maths.layout import ROTORS, STATE_SIZE
from mfi_drake.maths.motion import PACE_BLEND_SPEED
from mfi_drake.maths.quadcopter import attitude_gains, mixer_matrix
from mfi_drake.systems.exchange import message
from mfi_drake.systems.relative import VELOCITY_SIGNAL_SIZE
from mfi_drake.world.fleets import antipodal_circle, with_vehicles
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

VEHICLE = VEHICLES["drake_default"]


def one(scenario):
    return dataclasses.replace(scenario, fleet_integration="one")


def crowded_fleet():
    """Four vehicles within sensing range of each other, one of them beside
    a sphere, flying at angles, some tilted and turning: every reading path
    (a static obstacle, vehicles, the rule of the road, both eq 21 modes)."""
    scene = load_scenario(f"{SCENARIOS}/three_spheres.yaml")
    ends = [
        ([0.0, 0.0, 1.5], [9.0, 0.0, 1.5]),
        ([1.1, 0.3, 1.6], [-6.0, 1.0, 1.5]),
        ([0.5, -1.2, 1.4], [0.8, 8.0, 1.5]),
        ([2.0, 1.5, 1.5], [2.3, 1.4, 1.6]),  # 0.3 m from its goal: PD
    ]
    scene = with_vehicles(scene, ends)
    rng = np.random.default_rng(7)
    states = np.zeros((len(ends), STATE_SIZE))
    states[:, 0:3] = [start for start, _ in ends]
    states[:, 3:6] = rng.uniform(-0.15, 0.15, (len(ends), 3))
    states[:, 6:9] = [[1.0, 0.1, 0.0], [-0.9, 0.2, 0.05], [0.1, 1.1, 0.0], [0.05, 0, 0]]
    states[:, 9:12] = rng.uniform(-0.3, 0.3, (len(ends), 3))
    return scene, states


def single_vehicle_rows(scene, states, modes):
    """The oracle: each vehicle's own single-vehicle diagram (separate
    integration's), given the others' exact states at this instant: its log
    row (every signal the diagram logs), and its sensor's readings of the
    scene alone."""
    rows, scene_readings = [], []
    positions, velocities = states[:, 0:3], states[:, 6:9]
    for k, flown in enumerate(vehicle_scenarios(scene)):
        flight = build_diagram(flown, "mfi")
        diagram = flight.diagram
        context = diagram.CreateDefaultContext()
        flight.plant.GetMyMutableContextFromRoot(context).SetContinuousState(states[k])
        diagram.GetInputPort("other_vehicles").FixValue(
            context, message(0.0, positions, velocities, k)
        )
        selector = diagram.GetSubsystemByName("selector")
        selector_context = selector.GetMyMutableContextFromRoot(context)
        selector_context.get_mutable_discrete_state_vector().SetAtIndex(0, modes[k])
        for name, out in (("log_mux", rows), ("scene_sensor", scene_readings)):
            system = diagram.GetSubsystemByName(name)
            port = system.get_output_port(0)
            out.append(port.Eval(system.GetMyContextFromRoot(context)))
    return np.array(rows), np.array(scene_readings)


def chain_arguments(scene, states, scene_readings, modes, compiled_form):
    """fleet_chain's arguments but `rows`, in Python's or numba's form."""
    flown = vehicle_scenarios(scene)
    K_P, K_D = attitude_gains(VEHICLE, scene.navigator)
    D_inv = np.linalg.inv(mixer_matrix(VEHICLE))
    field, params, vehicle = fields.obstacle_field, scene.navigator, VEHICLE
    goal_terms = fields.goal_terms
    if compiled_form:
        field = compiled.compiled(fields).obstacle_field
        goal_terms = compiled.compiled(fields).goal_terms
        params, vehicle = compiled.record(params), compiled.record(vehicle)
    else:
        D_inv = D_inv.tolist()  # as RotorMixer gives it
    attitude = params
    estimate = scene.relative_velocity
    return (
        field,
        states,
        scene_readings,
        np.zeros((len(states), VELOCITY_SIGNAL_SIZE)),  # no moving obstacle
        False,
        np.array(modes, float),
        np.array([s.goal for s in flown], float),
        params,
        goal_terms,  # eq 21's selector (MFI)
        vehicle,
        attitude,
        K_P,
        K_D,
        D_inv,
        VEHICLE.collision_radius,
        scene.sensor.radius,
        estimate.keep_right,
        estimate.own_pace,
        PACE_BLEND_SPEED,
        np.zeros((len(states), 0)),  # no escape rule (mfi-nc's memories, ...)
        None,
        0.0,
        escape.NO_GROUND,
        np.zeros((0, 3)),  # no user's field (its forces)
    )


def test_a_vehicles_row_is_what_its_single_vehicle_diagram_logs():
    scene, states = crowded_fleet()
    modes = [fields.MODE_CRUISE] * 3 + [fields.MODE_PD]
    want, scene_readings = single_vehicle_rows(scene, states, modes)
    arguments = chain_arguments(scene, states, scene_readings, modes, False)
    rows = np.zeros((len(states), fleet.ROW_SIZE))
    fleet.fleet_chain(*arguments, rows)
    # The same functions in the same order: equal to the last bit.
    np.testing.assert_array_equal(rows, want)
    slices = fleet.row_slices()
    assert (rows[:, slices["obstacle"]][:, 3] == 1.0).all()  # everyone sees
    assert scene_readings[0, 3] == 1.0  # vehicle 0 sees the first sphere
    assert rows[0, slices["obstacle_force_terms"]].any()
    assert rows[:, slices["mode"]].ravel().tolist() == modes

    # Compiled: the same but for √(x²+y²+z²) for math.hypot (last bits).
    arguments = chain_arguments(scene, states, scene_readings, modes, True)
    fast = np.zeros_like(rows)
    compiled.compiled(fleet).fleet_chain(*arguments, fast)
    np.testing.assert_allclose(fast, rows, rtol=1e-12, atol=1e-12)


def test_the_row_is_the_single_vehicle_log_layout():
    assert [(name, size) for name, size, _, _ in LOG_LAYOUT] == list(fleet.ROW)


def test_a_fleet_at_rest_at_its_goals_hovers_on_every_rotor():
    goals = [[0.0, 0.0, 2.0], [3.0, 0.0, 2.0], [0.0, 3.0, 2.0]]
    scene = one(with_vehicles(antipodal_circle(3), [(g, g) for g in goals]))
    chain = OneIntegratorFleet(scene, "mfi").chain
    context = chain.CreateDefaultContext()
    states = np.zeros((3, STATE_SIZE))
    states[:, 0:3] = goals
    chain.GetInputPort("states").FixValue(context, states.ravel())
    forces = chain.GetOutputPort("rotor_forces").Eval(context)
    weight = VEHICLE.mass * 9.81
    np.testing.assert_allclose(forces, weight / ROTORS / VEHICLE.kF, rtol=1e-12)


def test_two_vehicles_closing_head_on_turn_right_alike_without_work():
    scene = one(
        with_vehicles(
            antipodal_circle(2), [([0, 0, 2], [9, 0, 2]), ([1.2, 0.05, 2], [-9, 0, 2])]
        )
    )
    chain = OneIntegratorFleet(scene, "mfi").chain
    context = chain.CreateDefaultContext()
    states = np.zeros((2, STATE_SIZE))
    states[0, 0:3], states[0, 6:9] = [0.0, 0.0, 2.0], [1.0, 0.0, 0.0]
    states[1, 0:3], states[1, 6:9] = [1.2, 0.05, 2.0], [-1.0, 0.0, 0.0]
    chain.GetInputPort("states").FixValue(context, states.ravel())
    rows = chain.GetOutputPort("rows").Eval(context).reshape(2, fleet.ROW_SIZE)
    terms = rows[:, fleet.row_slices()["obstacle_force_terms"]]
    F_o = terms[:, 0:3] + terms[:, 3:6]
    assert np.linalg.norm(F_o[0]) > 0.1
    # Point-symmetric about their midpoint (each turns right), and ⟂ v.
    np.testing.assert_allclose(F_o[1], -F_o[0], atol=1e-12)
    np.testing.assert_allclose(
        np.einsum("ij,ij->i", F_o, states[:, 6:9]), 0, atol=1e-12
    )
    assert np.cross(states[0, 6:9], F_o[0])[2] < 0.0  # to the right


@pytest.mark.parametrize("name", ["swarm_circle", "swarm_corridor"])
def test_one_integrator_flies_the_swarms_as_separate_integration(name):
    scene = load_scenario(f"{SCENARIOS}/{name}.yaml")
    apart, together = simulate(scene).metrics, simulate(one(scene)).metrics
    assert together["outcome"] == apart["outcome"] == "success"
    # Measured: separations within 12 mm, paths within 6 mm, convergence
    # within 0.15 s (10 Hz exchanges against none).
    assert together["min_separation"] == pytest.approx(
        apart["min_separation"], abs=0.03
    )
    for a, b in zip(apart["vehicles"], together["vehicles"], strict=True):
        assert b["path_length"] == pytest.approx(a["path_length"], abs=0.02)
        assert b["convergence_time"] == pytest.approx(a["convergence_time"], abs=0.3)


def test_a_fleet_on_one_integrator_stops_where_two_vehicles_touch():
    scene = one(antipodal_circle(8))
    turned = dataclasses.replace(scene.relative_velocity, keep_right=0.0)
    scene = dataclasses.replace(scene, relative_velocity=turned)
    flown = simulate(scene, stop_at_contact=True)
    assert flown.metrics["outcome"] == "collision"
    assert flown.metrics["sim_time"] < scene.duration / 2
    assert -0.01 < flown.metrics["min_separation"] <= 0.0


@pytest.mark.parametrize(
    "change, method, named",
    [
        ({"sensor": "cameras"}, "mfi-nc", "sensor: the compiled chain flies the"),
        ({"sensor": "cameras"}, "mfi", "sensor"),
    ],
)
def test_what_one_integrator_cannot_fly_is_refused_by_name(change, method, named):
    scene = one(load_scenario(f"{SCENARIOS}/swarm_corridor.yaml"))
    if change:
        scene = load_scenario(
            f"{SCENARIOS}/swarm_corridor.yaml",
            [("cameras", "fleet_integration: one\nsensor: !DepthCamera {}")],
        )
    with pytest.raises(ScenarioError, match=named):
        check_engine(scene, [method])


def test_run_refuses_a_method_one_integrator_cannot_fly_before_flying(capsys):
    path = f"{SCENARIOS}/swarm_corridor.yaml"
    argv = ["run", path, "--method", "gf", "--set", "fleet_integration: one"]
    argv += ["--set", "relative_velocity: {enabled: false}"]
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2 and "fleet_integration = 'one'" in err
    assert "relative_velocity.enabled = false" in err


def test_an_unknown_fleet_integration_is_refused_by_name(capsys):
    path = f"{SCENARIOS}/swarm_corridor.yaml"
    assert main(["run", path, "--set", "fleet_integration: fast"]) == 2
    assert "fleet_integration = 'fast': must be one of" in capsys.readouterr().err


def test_a_fleet_on_one_integrator_ends_once_every_vehicle_has_settled():
    scene = one(load_scenario(f"{SCENARIOS}/swarm_corridor.yaml"))
    whole, settled = simulate(scene).metrics, simulate(scene, until_settled=True)
    m = settled.metrics
    assert m["outcome"] == whole["outcome"] == "success"
    assert m["sim_time"] < scene.duration - 5.0
    # The rest of the whole flight is the hover: the same convergence, and
    # the final errors within the integrator's accuracy.
    assert (
        m["vehicles"][1]["convergence_time"] == whole["vehicles"][1]["convergence_time"]
    )
    for v in m["vehicles"]:
        assert v["final_error"] <= scene.simulator.accuracy
