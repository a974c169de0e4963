"""A long flight: 10 minutes simulated, almost all of it hovering at the
goal. The log grows by one row per integrator step, and while hovering the
steps are the SimulatorConfig's max_step_size, so its memory is a fixed
rate per simulated second, not more."""

import os
import resource

import numpy as np

from mfi_drake.flight.diagram import LOG_LAYOUT
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

DURATION = 600.0  # s


def test_ten_minute_flight_hovers_at_the_goal_with_a_log_of_fixed_rate():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    scenario.duration = DURATION
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB
    flight = simulate(scenario)
    growth_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    m = flight.metrics
    assert m["success"] and m["sim_time"] == DURATION, m
    # It stays at the goal for the whole hover, not only at the end.
    hover = flight.times > m["convergence_time"]
    error = np.linalg.norm(flight.positions[hover] - scenario.goal, axis=1)
    assert error.max() <= scenario.goal_tolerance
    # Hovering, every step but the one landing on DURATION is the largest
    # allowed: 10 rows per simulated second.
    late = flight.times > m["convergence_time"] + 10.0
    step = scenario.simulator.max_step_size
    np.testing.assert_allclose(np.diff(flight.times[late])[:-1], step, rtol=1e-9)
    rows = len(flight.times)
    columns = sum(size for _, size, _, _ in LOG_LAYOUT) + 1  # + the time
    log_mb = rows * columns * 8 / 1e6
    assert log_mb < 3.0, log_mb  # 6768 rows × 53 doubles ≈ 2.9 MB measured
    # The process grew by the log and its copies, nothing that scales worse.
    assert growth_mb < 10 * log_mb + 20, (growth_mb, log_mb)
