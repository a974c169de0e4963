"""The Simulator monitors that end a flight early: `settled_monitor` once
the vehicle has rested at its goal (`RestClock`), where the scenario
`settles`; `contact_monitor` at the first contact (`in_contact`)."""

import math
from dataclasses import replace

import numpy as np
from pydrake.systems.framework import EventStatus

from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import Scenario, SphereSensor
from mfi_drake.flight.diagram import FlightDiagram
from mfi_drake.maths.layout import (
    ANGULAR_RATE,
    ATTITUDE,
    POSITION,
    STATE_SIZE,
    VELOCITY,
    readings,
)
from mfi_drake.world.motion import is_dynamic

SETTLE_HOLD = 1.0  # [s] see settled_monitor


# [m] contact_monitor's reading must be this far inside the collision radius,
# so that rounding (|r_o| = |d| |∇d|) cannot end a flight the metrics, which
# read d itself, would not call collided.
CONTACT_MARGIN = 1e-9

RESTING = EventStatus.Severity.kReachedTermination  # what settled_monitor says


def settles(scenario: Scenario) -> bool:
    """Whether a flight of `scenario` that has come to rest at its goal stays
    there: nothing else moves, the sphere sensor (a camera's memory changes
    with time) and no faults (their noise does not rest)."""
    quiet = replace(scenario.faults, seed=Faults.seed, sample_rate=Faults.sample_rate)
    return (
        not is_dynamic(scenario)
        and isinstance(scenario.sensor, SphereSensor)
        and quiet == Faults()
    )


def settled_monitor(flight: FlightDiagram):
    """A Simulator monitor that ends the flight once the vehicle has been at
    rest at its goal for SETTLE_HOLD: its position, velocity, roll, pitch and
    angular rates all within ε = the integrator's accuracy of a hover at the
    goal at every step of that time. The rest of the flight is that hover,
    so its metrics are known to within ~ε: the outcome, clearance and
    convergence time do not change, the final error and the path still to
    fly are of the order of ε (≤ 1.7e-4 m at ε = 1e-4 over 24 random-field
    flights of every method); sim_time and steps are the flight's own.
    Used by sweeps (their flights last 60 s; MFI's settle by ~20–30 s,
    which spares a fifth of their steps); a run flies its whole duration."""
    plant, scenario = flight.plant, flight.scenario
    clock = RestClock([scenario.goal], scenario.simulator.accuracy)

    def monitor(context) -> EventStatus:
        state = plant.GetMyContextFromRoot(context).get_continuous_state_vector()
        if clock.settled(context.get_time(), state.CopyToVector()[None]):
            return EventStatus.ReachedTermination(plant, "settled at the goal")
        return EventStatus.Succeeded()

    return monitor


class RestClock:
    """Whether vehicles have rested at their goals for SETTLE_HOLD: their
    positions, velocities, roll, pitch and angular rates all within ε of a
    hover at the goal at every step of that time (`settled_monitor`)."""

    # At rest: roll, pitch, the velocity and the angular rates all zero.
    _index = np.arange(STATE_SIZE)
    STILL = np.r_[_index[ATTITUDE][:2], _index[VELOCITY], _index[ANGULAR_RATE]]

    def __init__(self, goals, epsilon: float):
        self._goals = np.array(goals, float)
        self._epsilon = epsilon
        self._since = None  # when the hover began

    def settled(self, t: float, states: np.ndarray) -> bool:
        """At time t, the vehicles at `states` (n, 12)."""
        at_rest = (
            np.abs(states[:, POSITION] - self._goals).max() <= self._epsilon
            and np.abs(states[:, self.STILL]).max() <= self._epsilon
        )
        if not at_rest:
            self._since = None
        elif self._since is None:
            self._since = t
        return at_rest and t - self._since >= SETTLE_HOLD


def centre_gap(positions: np.ndarray) -> float:
    """The least distance between two of the centres `positions` (n ≥ 2, 3)."""
    gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)
    return float(gaps[np.triu_indices(len(positions), 1)].min())


def in_contact(reading: np.ndarray, radius: float) -> bool:
    """Whether a sphere sensor's `reading` is closer than `radius` (less
    CONTACT_MARGIN) to the vehicle centre."""
    for r_o, seen in readings(reading):
        if seen > 0.5 and math.hypot(*r_o) < radius - CONTACT_MARGIN:
            return True
    return False


def contact_monitor(flight: FlightDiagram):
    """A Simulator monitor that ends the flight at the first step where a
    vehicle's sphere sensor reads an obstacle (or another vehicle's sphere)
    closer than its collision radius: the outcome is then "collision"
    whatever follows (`outcome`), and what follows can be long. The reading
    is the signed distance SceneGraph gives, the one `flight_metrics`
    measures the clearance with at the same logged step: a flight it ends
    is one the metrics call collided. (A vehicle pressed against an obstacle
    by eq 15's r⁻³ force, up to 1e9 N at contact, chatters along it at 10⁵
    steps: minutes of a sweep for a known outcome.) Read before any sensor
    fault, for sphere sensors only: a camera's reading is a percept. Among
    several vehicles it reads the scene alone (the input of
    `OtherVehicleReadings`): the others' spheres there are extrapolated,
    and `fly_fleet` judges their contacts from the exchanged true states."""
    radius = flight.vehicle.collision_radius
    sensor = flight.sensor
    port = sensor.GetOutputPort("obstacle")
    if flight.scenario.other_vehicles:
        port = sensor.GetInputPort("obstacle")
    if not isinstance(flight.scenario.sensor, SphereSensor):
        return lambda context: EventStatus.Succeeded()

    def monitor(context) -> EventStatus:
        if in_contact(port.Eval(sensor.GetMyContextFromRoot(context)), radius):
            return EventStatus.ReachedTermination(sensor, "in contact")
        return EventStatus.Succeeded()

    return monitor


def first_of(monitors):
    """One Simulator monitor: the first of `monitors` that does not succeed."""

    def monitor(context) -> EventStatus:
        for each in monitors:
            status = each(context)
            if status.severity() != EventStatus.Severity.kSucceeded:
                return status
        return EventStatus.Succeeded()

    return monitor
