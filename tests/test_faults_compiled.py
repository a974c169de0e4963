"""Faults on the compiled engine (docs/robustness.md, "On the compiled
engine"): a lone vehicle with every fault on, flown on both engines, equal
to the last bit (the chain reads the state estimate and the faulted
readings, the plant the faulted rotors, the log the truth); a fleet with
faults stays refused, by name. Oracle: the systems engine, the card's
diagram with `systems.faults`' systems between its blocks."""

import dataclasses
import functools

import numpy as np
import pytest

from mfi_drake.flight.fleet import unsupported
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.fleets import with_vehicles
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

EVERY_FAULT = (
    "faults: {sensor_noise_std: 0.05, dropout_prob: 0.1, sensor_latency: 0.04, "
    "motor_time_constant: 0.02, motor_time_constant_down: 0.03, weak_rotor: 2, "
    "weak_rotor_fraction: 0.9, position_noise_std: 0.02, "
    "velocity_noise_std: 0.03, seed: 7}"
)


@functools.cache
def flight(name: str, method: str, engine: str, duration: float):
    scenario = load_scenario(f"{SCENARIOS}/{name}.yaml", [("faults", EVERY_FAULT)])
    return simulate(
        dataclasses.replace(scenario, engine=engine, duration=duration), method
    )


def assert_same_flight(name: str, method: str, duration: float) -> None:
    systems = flight(name, method, "systems", duration)
    fast = flight(name, method, "compiled", duration)
    assert fast.metrics["engine"] == "compiled"
    np.testing.assert_array_equal(fast.times, systems.times)
    assert fast.log.keys() == systems.log.keys()
    for key, values in systems.log.items():
        np.testing.assert_array_equal(fast.log[key], values, err_msg=key)


@pytest.mark.parametrize("method", ["mfi", "mfi-paper", "apf", "gf"])
def test_every_fault_flies_the_same_flight_on_both_engines(method):
    """The planar wall within reach by 6 s: the faulted readings steer."""
    assert_same_flight("planar_wall", method, 6.0)
    log = flight("planar_wall", method, "compiled", 6.0).log
    # The log keeps the truth: the sensor's readings, not the noisy ones the
    # chain read (noise-free, a wall's reading changes smoothly).
    seen = log["obstacle"][:, 3] > 0.5
    assert seen.sum() > 100
    jumps = np.abs(np.diff(log["obstacle"][seen, :3], axis=0)).max()
    assert jumps < 0.01


def test_faults_among_moving_obstacles_fly_the_same_flight():
    """The velocity estimator reads the faulted readings and the state
    estimate on both engines."""
    assert_same_flight("moving_crossing", "gf", 5.5)
    assert (
        flight("moving_crossing", "gf", "compiled", 5.5).log["obstacle"][:, 3]
    ).any()


def test_a_fleet_with_faults_is_refused_on_the_compiled_engine_by_name():
    scenario = load_scenario(f"{SCENARIOS}/planar_wall_faults.yaml")
    assert unsupported(dataclasses.replace(scenario, engine="compiled"), "mfi") is None
    fleet = with_vehicles(
        scenario, [(scenario.start, scenario.goal), (scenario.goal, scenario.start)]
    )
    assert unsupported(fleet, "mfi") == (
        "faults: the compiled chain flies them for a lone vehicle only"
    )
