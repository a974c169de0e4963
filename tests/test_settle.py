"""A flight that ends once its vehicle has settled at the goal (what sweeps
fly, `monitors.settled_monitor`) has the whole flight's metrics within
the integrator's accuracy, and only flights that stay at rest end early.
A flight that ends at its first contact (`monitors.contact_monitor`) is
the whole flight's first part, and ends at the step the sphere's closed
form calls the first contact."""

from dataclasses import replace

import numpy as np
import pytest

from mfi_drake.config.dynamic import Motion
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Obstacle, Scenario, Sphere
from mfi_drake.config.sensors import DepthCamera
from mfi_drake.flight.monitors import settles
from mfi_drake.flight.simulation import simulate

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


def straight_at_the_goal(position, velocity, obstacle_points, goal):
    """A user field that pulls to the goal and ignores every obstacle."""
    return 1.5 * (np.asarray(goal) - position) - 2.0 * velocity


def test_a_flight_ends_at_its_first_contact_and_only_then():
    sphere = SCENARIO.obstacles[0]
    centre, reach = np.array(sphere.position), sphere.shape.radius
    whole = simulate(SCENARIO, straight_at_the_goal)
    stopped = simulate(SCENARIO, straight_at_the_goal, stop_at_contact=True)
    assert whole.metrics["outcome"] == stopped.metrics["outcome"] == "collision"
    assert stopped.metrics["sim_time"] < 0.5 * whole.metrics["sim_time"]
    # The closed form: the collision sphere's clearance from the sphere.
    clearance = (
        np.linalg.norm(stopped.positions - centre, axis=1)
        - reach
        - stopped.collision_radius
    )
    assert clearance[-1] < 0.0 and np.all(clearance[:-1] >= 0.0)
    # What it flew is the whole flight's beginning, step for step.
    k = len(stopped.times)
    assert np.array_equal(stopped.times, whole.times[:k])
    for name, values in stopped.log.items():
        assert np.array_equal(values, whole.log[name][:k]), name
    # A flight that never touches is flown whole.
    clear = simulate(SCENARIO, "mfi", stop_at_contact=True)
    assert clear.metrics["outcome"] == "success"
    assert clear.metrics["sim_time"] == SCENARIO.duration
