"""A flight's result: the `Flight` (the log, arrays by name), its metrics
(`flight_metrics`; docs/usage.md defines each) and `outcome`, the one place
that says what a flight's result was."""

from dataclasses import dataclass, field

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.maths.layout import POSITION
from mfi_drake.world.obstacles import obstacle_distances

CLEARANCE_REACH = 2.0  # [m] see flight_metrics


@dataclass
class Flight:
    """One simulated flight: the scenario, the log and the metrics."""

    scenario: Scenario
    method: str  # its registry name, or a user field's MODULE:NAME
    sensor: str
    collision_radius: float
    times: np.ndarray
    log: dict[str, np.ndarray]  # name -> (N, size) array, see diagram.LOG_LAYOUT
    wall_time: float
    cpu_time: float = 0.0  # process CPU time of the simulation [s]
    integrator_steps: int = 0  # steps the integrator took
    derivative_evaluations: int = 0  # its time-derivative evaluations
    frames_rendered: int | None = None  # depth-camera frames (None: no camera)
    metrics: dict = field(default_factory=dict)
    # Ended by the escape rule, out of options (`simulator.ended_trapped`).
    trapped: bool = False
    # The scenario's other_vehicles, flown at once: one Flight each (wall
    # and CPU times are the whole fleet's).
    others: list["Flight"] = field(default_factory=list)

    @property
    def positions(self) -> np.ndarray:
        return self.log["state"][:, POSITION]


OUTCOMES = ("success", "collision", "timeout", "trapped")


def outcome(metrics: dict) -> str:
    """A flight's result: "collision" if its clearance went below zero at any
    logged step (reached or not), else "success" if it ended within the goal
    tolerance, else "trapped" if the escape rule ended it, out of options
    (metrics "trapped", only a flight of "mfi" can), else "timeout"
    (stuck, or too slow for the duration). Among several vehicles:
    "collision" if any collided or two touched (min_separation ≤ 0), else
    "success" if every one reached its goal, else "trapped" if one was
    (its trap ended the fleet's flight)."""
    vehicles = metrics.get("vehicles", [metrics])
    touched = metrics.get("min_separation", np.inf) <= 0.0
    if touched or any(v["collided"] for v in vehicles):
        return "collision"
    if all(v["reached"] for v in vehicles):
        return "success"
    return "trapped" if any(v.get("trapped") for v in vehicles) else "timeout"


VEHICLE_KEYS = ("success", "reached", "collided", "min_clearance", "path_length")

VEHICLE_KEYS += ("final_error", "convergence_time")


def several_vehicles(flight: Flight, metrics: dict) -> dict:
    """What a flight of several vehicles adds to the first one's `metrics`:
    `vehicles` (each one's VEHICLE_KEYS, the first included, and "trapped"
    where it is),
    `min_separation` (`least_separation`) and `success`, true only when
    every vehicle succeeded and min_separation > 0."""
    everyone = [metrics] + [other.metrics for other in flight.others]
    separation = least_separation([flight, *flight.others])
    return {
        "vehicles": [
            {k: m[k] for k in (*VEHICLE_KEYS, "trapped") if k in m} for m in everyone
        ],
        "min_separation": separation,
        "success": all(m["success"] for m in everyone) and separation > 0.0,
    }


def least_separation(flights: list[Flight]) -> float:
    """The least distance between two vehicles' centres minus their two
    collision radii. Each vehicle logs at its own integrator's steps: a
    pair is compared at every logged time of either, the other's position
    interpolated linearly between its logged steps."""
    gaps = [np.inf]
    for i, first in enumerate(flights):
        for second in flights[i + 1 :]:
            for a, b in ((first, second), (second, first)):
                p = [np.interp(a.times, b.times, b.positions[:, d]) for d in range(3)]
                gap = np.linalg.norm(a.positions - np.column_stack(p), axis=1)
                gaps.append(gap.min())
    return float(min(gaps)) - 2.0 * flights[0].collision_radius


def fleet_flight(flights: list[Flight]) -> Flight:
    """The first vehicle's Flight with the others in `others`, every one
    with its metrics (the first's over the fleet)."""
    for other in flights[1:]:
        other.metrics = flight_metrics(other)
    result = flights[0]
    result.others = flights[1:]
    result.metrics = flight_metrics(result)
    return result


def flight_metrics(flight: Flight) -> dict:
    """The run's numbers (docs/usage.md defines each)."""
    scenario = flight.scenario
    times, p = flight.times, flight.positions
    goal = np.asarray(scenario.goal, float)
    error = np.linalg.norm(p - goal, axis=1)
    path_length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    if scenario.obstacles or scenario.ground is not None or scenario.map_points:
        # Exact: a point with nothing within the reach is farther than any
        # distance found. Only a flight that never came near anything needs
        # the query against every obstacle. Moving obstacles are where they
        # were at each logged time.
        distances = obstacle_distances(scenario, p, CLEARANCE_REACH, times)
        if not np.isfinite(distances).any():
            distances = obstacle_distances(scenario, p, times=times)
        min_clearance = float(np.min(distances)) - flight.collision_radius
    else:
        min_clearance = float("inf")
    tolerance = scenario.goal_tolerance
    reached = bool(error[-1] <= tolerance)
    convergence_time = None
    if reached:
        outside = np.nonzero(error > tolerance)[0]
        convergence_time = float(times[outside[-1] + 1] if len(outside) else times[0])
    collided = bool(min_clearance < 0.0)
    sim_time = float(times[-1])
    metrics = {
        "scenario": scenario.name,
        "method": flight.method,
        "sensor": flight.sensor,
        "vehicle": as_vehicle(scenario.vehicle).name,
        "reached": reached,
        "collided": collided,
        "success": reached and not collided,  # = outcome(...) == "success"
        "min_clearance": min_clearance if np.isfinite(min_clearance) else None,
        "path_length": path_length,
        "final_error": float(error[-1]),
        "convergence_time": convergence_time,
        "sim_time": sim_time,
        "wall_time": flight.wall_time,
        "realtime_factor": sim_time / flight.wall_time,
        "steps": int(len(times)),
        "saturated_fraction": float(np.mean(flight.log["saturation"][:, 0] > 0)),
    }
    if flight.trapped:  # only then: the metrics of every other flight unchanged
        metrics["trapped"] = True
    if flight.others:
        metrics.update(several_vehicles(flight, metrics))
    metrics["outcome"] = outcome(metrics)
    if flight.frames_rendered is not None:
        metrics["frames_rendered"] = flight.frames_rendered
    return metrics
