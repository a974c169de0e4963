"""A flight that ends once its vehicle has settled at the goal (what sweeps
fly, `simulation.settled_monitor`) has the whole flight's metrics within
the integrator's accuracy, and only flights that stay at rest end early."""

from dataclasses import replace

import pytest

from mfi_drake.config.dynamic import Motion
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import DepthCamera, Obstacle, Scenario, Sphere
from mfi_drake.flight.simulation import settles, simulate

SCENARIO = Scenario(
    start=[0.0, 0.0, 1.5],
    goal=[5.0, 0.0, 1.5],
    duration=30.0,
    obstacles=[Obstacle(Sphere(0.5), [2.5, 0.1, 1.5])],
)


@pytest.mark.parametrize("method", ["mfi", "gf"])
def test_a_settled_flight_has_the_whole_flights_metrics(method):
    whole = simulate(SCENARIO, method).metrics
    settled = simulate(SCENARIO, method, until_settled=True).metrics
    epsilon = SCENARIO.simulator.accuracy
    assert whole["sim_time"] == SCENARIO.duration
    assert settled["sim_time"] < 0.7 * SCENARIO.duration
    assert settled["steps"] < whole["steps"]
    for key in ("outcome", "reached", "collided", "min_clearance"):
        assert settled[key] == whole[key], key
    assert settled["convergence_time"] == whole["convergence_time"]
    assert settled["final_error"] <= epsilon
    assert settled["path_length"] == pytest.approx(
        whole["path_length"], abs=3 * epsilon
    )


def test_only_flights_that_stay_at_rest_end_early():
    assert settles(SCENARIO)
    assert settles(replace(SCENARIO, faults=Faults(seed=7, sample_rate=20.0)))
    assert not settles(replace(SCENARIO, faults=Faults(sensor_noise_std=0.01)))
    assert not settles(replace(SCENARIO, sensor=DepthCamera()))
    moving = replace(
        SCENARIO.obstacles[0],
        motion=Motion(amplitude=[1.0, 0, 0], angular_frequency=[1.0] * 3),
    )
    assert not settles(replace(SCENARIO, obstacles=[moving]))
    # Where it does not settle, until_settled flies the whole duration.
    noisy = replace(SCENARIO, faults=Faults(position_noise_std=0.01))
    assert simulate(noisy, until_settled=True).metrics["sim_time"] == 30.0
