"""The fault models (issue 7) against closed forms and statistics, their
validation, their place in the diagram, and the faulted planar_wall flight."""

import dataclasses
import io
import math
import os

import distributed
import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator, Multiplexer

from mfi_drake.app.cli import main
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.config.scenario_yaml import read_faults
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulate
from mfi_drake.flight.simulator import fly
from mfi_drake.maths.faults import corrupt_reading, sample_rng
from mfi_drake.studies.records import read_results
from mfi_drake.studies.sweep import SweepConfig, run_sweep
from mfi_drake.studies.variants import fault_variant, with_faults
from mfi_drake.systems.faults import MotorLag, SensorFaults, StateEstimateError
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

FAULT_SYSTEMS = {"sensor_faults", "state_estimate", "motor_lag", "weak_rotor"}


def _run(system, source_values, times, clock=False):
    """Simulates `system` fed by constant `source_values` (prefixed by the
    time t when `clock`); returns its output at each of `times`."""
    builder = DiagramBuilder()
    builder.AddSystem(system)
    source = builder.AddSystem(ConstantVectorSource(np.asarray(source_values, float)))
    port = source.get_output_port(0)
    if clock:
        one = builder.AddSystem(ConstantVectorSource([1.0]))
        integrator = builder.AddSystem(Integrator(1))
        builder.Connect(one.get_output_port(0), integrator.get_input_port(0))
        mux = builder.AddSystem(Multiplexer([1, len(source_values)]))
        builder.Connect(integrator.get_output_port(0), mux.get_input_port(0))
        builder.Connect(port, mux.get_input_port(1))
        port = mux.get_output_port(0)
    builder.Connect(port, system.get_input_port(0))
    simulator = Simulator(builder.Build())
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    context = simulator.get_mutable_context()
    out = []
    for t in times:
        simulator.AdvanceTo(t)
        out.append(system.get_output_port(0).Eval(system.GetMyContextFromRoot(context)))
    return np.array(out)


def test_latency_delays_the_reading_by_whole_sample_periods():
    # Input r_o = [t, 0, 0], seen; with no noise the output's first entry is
    # the sample time of the reading it holds: the last sample minus the delay.
    rate, latency = 50.0, 0.1
    faults = Faults(sample_rate=rate, sensor_latency=latency)
    times = np.arange(0.005, 2.0, 0.013)
    out = _run(SensorFaults(faults, 4), [0.0, 0.0, 1.0], times, clock=True)
    for t, o in zip(times, out, strict=True):
        sampled = math.floor(t * rate) / rate - latency
        if sampled < -1e-9:  # nothing has come through the delay line yet
            np.testing.assert_array_equal(o, 0.0)
        else:
            np.testing.assert_allclose(o, [sampled, 0.0, 0.0, 1.0], atol=1e-9)


def test_sensor_noise_and_dropouts_have_the_set_statistics_and_are_held():
    faults = Faults(sample_rate=100.0, sensor_noise_std=0.2, dropout_prob=0.25, seed=7)
    r_o = np.array([1.0, -2.0, 0.5])
    # Two evaluations inside each sample period see the same sample.
    times = np.repeat(np.arange(1, 2001) / 100.0, 2) + np.tile([0.002, 0.008], 2000)
    out = _run(SensorFaults(faults, 4), [*r_o, 1.0], times)
    np.testing.assert_array_equal(out[0::2], out[1::2])
    out = out[0::2]
    lost = out[:, 3] == 0.0
    np.testing.assert_array_equal(out[lost], 0.0)  # "nothing seen" when lost
    # 2000 Bernoulli(0.25) samples: 4.5 standard deviations is 87.
    assert abs(lost.sum() - 500) < 87
    noise = out[~lost, :3] - r_o
    assert abs(noise.mean()) < 0.02
    assert noise.std() == pytest.approx(0.2, rel=0.05)


def test_noise_is_a_function_of_seed_and_sample_index_only():
    reading = np.array([1.0, 2.0, 3.0, 1.0])
    a = corrupt_reading(reading, sample_rng(3, 0, 41), 0.1, 0.2)
    b = corrupt_reading(reading, sample_rng(3, 0, 41), 0.1, 0.2)
    c = corrupt_reading(reading, sample_rng(4, 0, 41), 0.1, 0.2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # Nothing seen stays nothing seen: noise never invents an obstacle.
    np.testing.assert_array_equal(
        corrupt_reading(np.zeros(4), sample_rng(0, 0, 0), 1.0, 0.0), 0.0
    )


def test_state_estimate_error_perturbs_only_position_and_velocity():
    faults = Faults(sample_rate=100.0, position_noise_std=0.3, velocity_noise_std=0.1)
    x = np.arange(12.0)
    times = np.arange(1, 1001) / 100.0 + 0.005
    error = _run(StateEstimateError(faults), x, times) - x
    np.testing.assert_array_equal(error[:, 3:6], 0.0)
    np.testing.assert_array_equal(error[:, 9:12], 0.0)
    assert error[:, 0:3].std() == pytest.approx(0.3, rel=0.06)
    assert error[:, 6:9].std() == pytest.approx(0.1, rel=0.06)


@pytest.mark.parametrize("command", [3.0, 0.5])
def test_motor_lag_is_the_first_order_step_response(command):
    # From 2.0 to `command`: u(t) = c + (u0 − c) e^(−t/τ), τ = 0.0125 s up,
    # 0.025 s down (RotorS' Pelican).
    tau_up, tau_down, u0 = 0.0125, 0.025, 2.0
    tau = tau_up if command > u0 else tau_down
    times = np.array([0.005, 0.0125, 0.03, 0.1])
    out = _run(MotorLag(tau_up, tau_down, np.full(4, u0)), np.full(4, command), times)
    expected = command + (u0 - command) * np.exp(-times / tau)
    np.testing.assert_allclose(out, np.outer(expected, np.ones(4)), atol=1e-6)


def _system_names(scenario):
    diagram = build_diagram(scenario).diagram
    return {s.get_name() for s in diagram.GetSystems()}


def test_faults_are_inserted_only_when_on():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    assert not _system_names(scenario) & FAULT_SYSTEMS
    scenario.faults = Faults(
        sensor_noise_std=0.01,
        position_noise_std=0.01,
        motor_time_constant=0.01,
        weak_rotor_fraction=0.9,
    )
    assert _system_names(scenario) & FAULT_SYSTEMS == FAULT_SYSTEMS
    for name, faults in [
        ("sensor_faults", Faults(dropout_prob=0.1)),
        ("sensor_faults", Faults(sensor_latency=0.05)),
        ("state_estimate", Faults(velocity_noise_std=0.1)),
        ("motor_lag", Faults(motor_time_constant=0.01)),
        ("weak_rotor", Faults(weak_rotor_fraction=0.0)),
    ]:
        scenario.faults = faults
        assert _system_names(scenario) & FAULT_SYSTEMS == {name}


def test_weak_rotor_scales_one_rotor_and_the_log_keeps_the_true_state():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    scenario.duration = 2.0
    scenario.faults = Faults(
        weak_rotor=2, weak_rotor_fraction=0.8, position_noise_std=0.5
    )
    built = build_diagram(scenario)
    flight = fly(built)
    diagram = built.diagram
    context = diagram.CreateDefaultContext()
    mixer = diagram.GetSubsystemByName("mixer")
    u = mixer.GetOutputPort("propeller_force").Eval(mixer.GetMyContextFromRoot(context))
    plant_u = built.plant.get_input_port(0).Eval(
        built.plant.GetMyContextFromRoot(context)
    )
    np.testing.assert_allclose(plant_u, u * [1.0, 1.0, 0.8, 1.0])
    # The estimate jumps by ~0.5 m every 20 ms; the logged state does not.
    p = flight.positions
    assert np.max(np.linalg.norm(np.diff(p, axis=0), axis=1)) < 0.05


@pytest.mark.parametrize(
    "faults, field",
    [
        ("{dropout_prob: 1.5}", "faults.dropout_prob"),
        ("{sensor_noise_std: -0.1}", "faults.sensor_noise_std"),
        ("{sample_rate: 0}", "faults.sample_rate"),
        ("{weak_rotor: 4}", "faults.weak_rotor"),
        ("{weak_rotor: 1.5}", "faults.weak_rotor"),
        ("{weak_rotor_fraction: 1.2}", "faults.weak_rotor_fraction"),
        ("{motor_time_constant_down: 0.02}", "faults.motor_time_constant_down"),
        ("{sensor_latency: 100.0}", "faults.sensor_latency"),
        ("{seed: -1}", "faults.seed"),
        ("{position_noise_std: .nan}", "faults.position_noise_std"),
        ("{velocity_noise: 0.1}", "faults.velocity_noise"),
        ("0.1", "faults"),
    ],
)
def test_bad_faults_are_rejected_naming_the_field(write_yaml, faults, field):
    path = write_yaml(f"name: x\ngoal: [5, 0, 1.5]\nfaults: {faults}\n")
    with pytest.raises(ScenarioError, match=rf"{path}: {field} = "):
        load_scenario(path)


def test_same_seed_same_flight_other_seed_other_flight():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall_faults.yaml"))
    scenario.duration = 5.0
    a, b = simulate(scenario), simulate(scenario)
    np.testing.assert_array_equal(a.log["state"], b.log["state"])
    scenario.faults.seed = 1
    c = simulate(scenario)
    assert not np.allclose(a.log["state"][-1], c.log["state"][-1])


def test_planar_wall_with_faults_reaches_the_goal_without_collision():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall_faults.yaml"))
    assert scenario.faults == Faults(
        sensor_noise_std=0.05, dropout_prob=0.1, motor_time_constant=0.02
    )
    m = simulate(scenario).metrics
    assert m["success"], m
    assert m["min_clearance"] > 0.05


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_lagged_rotors_start_at_hover_so_a_vehicle_at_its_goal_stays(vehicle):
    scenario = Scenario(name="hover", start=[0.0, 0.0, 1.0], goal=[0.0, 0.0, 1.0])
    scenario.vehicle, scenario.duration = vehicle, 3.0
    scenario.faults = Faults(motor_time_constant=0.0125, motor_time_constant_down=0.025)
    p = simulate(scenario).positions
    assert np.max(np.abs(p - scenario.goal)) < 1e-6


def test_fault_systems_convert_to_autodiff_for_linearisation():
    faults = Faults(sensor_noise_std=0.1, position_noise_std=0.1)
    lag = MotorLag(0.0125, 0.025, np.full(4, 2.0)).ToAutoDiffXd()
    context = lag.CreateDefaultContext()
    lag.get_input_port(0).FixValue(context, [AutoDiffXd(1.0, [1.0])] * 4)
    rates = lag.EvalTimeDerivatives(context).CopyToVector()
    # Spinning down: du/dt = (u_cmd − u)/τ_down, ∂/∂u_cmd = 1/τ_down.
    assert [r.value() for r in rates] == pytest.approx([-40.0] * 4)
    assert [r.derivatives()[0] for r in rates] == pytest.approx([40.0] * 4)
    # Additive noise passes derivatives on unchanged.
    sensor = SensorFaults(faults, 4).ToAutoDiffXd()
    context = sensor.CreateDefaultContext()
    sensor.get_input_port(0).FixValue(context, [AutoDiffXd(1.0, [1.0])] * 4)
    sample = sensor.EvalUniquePeriodicDiscreteUpdate(context).get_vector()
    assert [x.derivatives()[0] for x in sample.CopyToVector()] == [1.0] * 4
    estimate = StateEstimateError(faults).ToAutoDiffXd()
    context = estimate.CreateDefaultContext()
    estimate.get_input_port(0).FixValue(context, [AutoDiffXd(1.0, [1.0])] * 12)
    out = estimate.get_output_port(0).Eval(context)
    assert [x.derivatives()[0] for x in out] == [1.0] * 12


def test_sweep_flies_every_field_with_the_faults_and_keys_the_records(tmp_path):
    faults = read_faults("{sensor_noise_std: 0.05, motor_time_constant: 0.02}", "t")
    variant = fault_variant(faults)
    assert variant == "sensor_noise_std=0.05,motor_time_constant=0.02"

    def modify(scenario):  # 1.5 s flights: cheap, and timeouts (replayable)
        return dataclasses.replace(with_faults(scenario, faults), duration=1.5)

    config = SweepConfig(n=2, methods=["mfi"], out=str(tmp_path), variant=variant)
    with distributed.Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as client:
        run = run_sweep(config, client, modify, progress_stream=io.StringIO())
    assert (run.ran, run.lost) == (2, [])
    records = read_results(str(tmp_path / "results.jsonl"))
    assert [r["variant"] for r in records] == [variant, variant]
    failures = tmp_path / "failures"
    names = [f for f in os.listdir(failures) if f.endswith(".yaml")]
    replays = [load_scenario(str(failures / f)) for f in names]
    assert len(replays) == 2
    for replay in replays:
        assert replay.faults.sensor_noise_std == 0.05
        assert replay.faults.motor_time_constant == 0.02
    assert len({r.faults.seed for r in replays}) == 2  # independent noise per field


@pytest.mark.parametrize("text", ["", "~", "null", "{}"])
def test_empty_faults_are_none(text):
    assert read_faults(text, "--faults") == Faults()


@pytest.mark.parametrize(
    "text, named",
    [
        ("{dropout_prob: 3}", "faults.dropout_prob = 3"),
        ("{noise: 1}", "faults.noise = 1: unknown field of Faults"),
        (
            "{sensor_noise_std: abc}",
            "faults.sensor_noise_std = 'abc': must be a number",
        ),
        ("[1]", "faults = [1]: must be a mapping of Faults fields"),
    ],
)
def test_sweep_rejects_bad_faults_in_one_line(tmp_path, capsys, text, named):
    assert main(["sweep", "--n", "1", "--out", str(tmp_path), "--faults", text]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--faults" in err and named in err, err
    assert not os.path.exists(tmp_path / "results.jsonl")
