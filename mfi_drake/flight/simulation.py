"""Flying a scenario: `simulate` runs the diagram and returns a `Flight`
(the log, arrays by name) with its metrics; `outcome` is the one place that
says what a flight's result was. A scenario with `other_vehicles` is flown
as a fleet (`fly_fleet`): one diagram and Simulator per vehicle, exchanging
positions at `exchange_hz`."""

import math
import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from multiprocessing.connection import Connection

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import EventStatus

from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import (
    Cameras,
    Scenario,
    SphereSensor,
    scenario_from_yaml,
    scenario_to_yaml,
)
from mfi_drake.flight.diagram import FlightDiagram, build_diagram, vehicle_scenarios
from mfi_drake.flight.fleet import OneIntegratorFleet
from mfi_drake.flight.methods import Method
from mfi_drake.maths.fleet import ROW_SIZE, row_slices
from mfi_drake.maths.layout import (
    ANGULAR_RATE,
    ATTITUDE,
    POSITION,
    STATE_SIZE,
    VELOCITY,
    readings,
)
from mfi_drake.systems.exchange import message
from mfi_drake.world.motion import is_dynamic
from mfi_drake.world.obstacles import obstacle_distances

CLEARANCE_REACH = 2.0  # [m] see flight_metrics
SETTLE_HOLD = 1.0  # [s] see settled_monitor
WITNESS_SCALE = 0.01  # Drake's witness isolation window over the context's accuracy
# [m] contact_monitor's reading must be this far inside the collision radius,
# so that rounding (|r_o| = |d| |∇d|) cannot end a flight the metrics, which
# read d itself, would not call collided.
CONTACT_MARGIN = 1e-9
RESTING = EventStatus.Severity.kReachedTermination  # what settled_monitor says


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
    # The scenario's other_vehicles, flown at once: one Flight each (wall
    # and CPU times are the whole fleet's).
    others: list["Flight"] = field(default_factory=list)

    @property
    def positions(self) -> np.ndarray:
        return self.log["state"][:, POSITION]


def simulate(
    scenario: Scenario,
    method: "str | Callable | Method" = "mfi",
    until_settled: bool = False,
    stop_at_contact: bool = False,
    processes: int = 1,
) -> Flight:
    """Builds the diagram of `scenario`, flies it for scenario.duration with the
    scenario's SimulatorConfig and returns the logged flight and its metrics.

    `method`: "mfi", "apf", "gf" (`methods.METHODS`), a user's navigation
    field as "MODULE:NAME" or as the function itself (see `methods`).
    `until_settled`, `stop_at_contact`: see `fly`. With `other_vehicles`,
    every vehicle is flown (`fly_fleet`), over `processes` processes; with
    `fleet_integration: one`, on one integrator in this process
    (`fly_one_integrator`)."""
    if scenario.other_vehicles and scenario.fleet_integration == "one":
        return fly_one_integrator(scenario, method, until_settled, stop_at_contact)
    if scenario.other_vehicles:
        return fly_fleet(scenario, method, until_settled, stop_at_contact, processes)
    return fly(build_diagram(scenario, method), until_settled, stop_at_contact)


OUTCOMES = ("success", "collision", "timeout")


def outcome(metrics: dict) -> str:
    """A flight's result: "collision" if its clearance went below zero at any
    logged step (reached or not), else "success" if it ended within the goal
    tolerance, else "timeout" (stuck, or too slow for the duration). Among
    several vehicles: "collision" if any collided or two touched
    (min_separation ≤ 0), else "success" if every one reached its goal."""
    vehicles = metrics.get("vehicles", [metrics])
    touched = metrics.get("min_separation", np.inf) <= 0.0
    if touched or any(v["collided"] for v in vehicles):
        return "collision"
    return "success" if all(v["reached"] for v in vehicles) else "timeout"


VEHICLE_KEYS = ("success", "reached", "collided", "min_clearance", "path_length")
VEHICLE_KEYS += ("final_error", "convergence_time")


def several_vehicles(flight: Flight, metrics: dict) -> dict:
    """What a flight of several vehicles adds to the first one's `metrics`:
    `vehicles` (each one's VEHICLE_KEYS, the first included),
    `min_separation` (`least_separation`) and `success`, true only when
    every vehicle succeeded and min_separation > 0."""
    everyone = [metrics] + [other.metrics for other in flight.others]
    separation = least_separation([flight, *flight.others])
    return {
        "vehicles": [{k: m[k] for k in VEHICLE_KEYS} for m in everyone],
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


def simulator_at_start(diagram, plant, scenario: Scenario) -> Simulator:
    """A Simulator of `diagram` with the scenario's SimulatorConfig, the
    plant (a subsystem of `diagram`) at the scenario's start, at rest."""
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    context = simulator.get_mutable_context()
    # The integrator's accuracy is set by the config. The context's is what
    # witness isolation reads: Drake locates a witness's zero (eq 21's mode
    # switches) to within 0.01 × that accuracy × 1 s. Set so that a switch is
    # located to the integrator's accuracy in seconds (1e-4 s at the
    # default), not 100 times finer: on the paper scenarios that is 3–9 %
    # fewer steps, path lengths within 1e-4 m, convergence times within 6 ms.
    context.SetAccuracy(min(1.0, scenario.simulator.accuracy / WITNESS_SCALE))
    place_at_start(plant, context, scenario.start)
    return simulator


def place_at_start(plant, context, start) -> None:
    """Puts `plant`, a subsystem of the diagram of `context`, at `start`, at
    rest."""
    x0 = np.zeros(STATE_SIZE)
    x0[POSITION] = start
    plant.GetMyMutableContextFromRoot(context).SetContinuousState(x0)


def run_timed(simulator: Simulator, duration: float) -> tuple[float, float]:
    """Initialize + AdvanceTo(duration); (wall time, process CPU time) [s]."""
    start, start_cpu = time.perf_counter(), time.process_time()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return time.perf_counter() - start, time.process_time() - start_cpu


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


def _first_of(monitors):
    """One Simulator monitor: the first of `monitors` that does not succeed."""

    def monitor(context) -> EventStatus:
        for each in monitors:
            status = each(context)
            if status.severity() != EventStatus.Severity.kSucceeded:
                return status
        return EventStatus.Succeeded()

    return monitor


def start_simulator(
    flight: FlightDiagram, until_settled: bool = False, stop_at_contact: bool = False
) -> Simulator:
    """A Simulator of the diagram from the scenario's start at rest, with
    the monitors of `fly`."""
    scenario = flight.scenario
    simulator = simulator_at_start(flight.diagram, flight.plant, scenario)
    monitors = []
    if until_settled and settles(scenario):
        monitors.append(settled_monitor(flight))
    if stop_at_contact:
        monitors.append(contact_monitor(flight))
    if monitors:
        simulator.set_monitor(_first_of(monitors))
    return simulator


def fly(
    flight: FlightDiagram, until_settled: bool = False, stop_at_contact: bool = False
) -> Flight:
    """Simulates an already built diagram from the scenario's start at rest.
    `until_settled`: end the flight once the vehicle rests at its goal
    (`settled_monitor`), where the scenario `settles`. `stop_at_contact`:
    end it when a sphere sensor reads contact (`contact_monitor`)."""
    simulator = start_simulator(flight, until_settled, stop_at_contact)
    wall_time, cpu_time = run_timed(simulator, flight.scenario.duration)
    result = logged(flight, simulator, wall_time, cpu_time)
    result.metrics = flight_metrics(result)
    return result


class FleetGroup:
    """Some of a fleet's vehicles (`indices` into `vehicle_scenarios`), each
    flown by its own diagram, Simulator and error control; `fly_fleet`
    drives one group per process."""

    def __init__(
        self,
        scenario: Scenario,
        method: "str | Callable | Method",
        indices: list[int],
        until_settled: bool,
        stop_at_contact: bool,
    ):
        flown = vehicle_scenarios(scenario)
        self.indices = list(indices)
        self.fleet = [build_diagram(flown[k], method) for k in self.indices]
        self.simulators = [
            start_simulator(flight, False, stop_at_contact) for flight in self.fleet
        ]
        self.contexts = [s.get_mutable_context() for s in self.simulators]
        self.ports = [f.diagram.GetInputPort("other_vehicles") for f in self.fleet]
        # Only where nothing but the vehicles moves (`settles` without them).
        quiet = until_settled and settles(replace(scenario, other_vehicles=[]))
        self.settled = [
            (settled_monitor(f), c)
            for f, c in zip(self.fleet, self.contexts, strict=True)
            if quiet
        ]
        self.cpu_time = 0.0

    def states(self) -> np.ndarray:
        """(its vehicles, STATE_SIZE): where they are now."""
        return np.array(
            [
                flight.plant.GetMyContextFromRoot(context)
                .get_continuous_state_vector()
                .CopyToVector()
                for flight, context in zip(self.fleet, self.contexts, strict=True)
            ]
        )

    def step(self, t: float, states: np.ndarray, until: float | None) -> tuple:
        """Gives each of its vehicles the exchange at time t (`states`: the
        whole fleet's), then advances them to `until` (None: initializes
        them). Returns (its states, whether a contact monitor ended a
        flight, whether every vehicle has rested at its goal for
        SETTLE_HOLD: each settled monitor sees every exchange)."""
        start = time.process_time()
        positions, velocities = states[:, POSITION], states[:, VELOCITY]
        for k, port, context in zip(
            self.indices, self.ports, self.contexts, strict=True
        ):
            port.FixValue(context, message(t, positions, velocities, k))
        for simulator in self.simulators:
            if until is None:
                simulator.Initialize()
            else:
                simulator.AdvanceTo(until)
        ended = until is not None and any(c.get_time() < until for c in self.contexts)
        # A list, not a generator: every monitor must see every exchange.
        resting = [m(c).severity() == RESTING for m, c in self.settled]
        at_rest = bool(resting) and all(resting)
        self.cpu_time += time.process_time() - start
        return self.states(), ended, at_rest

    def flights(self, wall_time: float) -> list[Flight]:
        """Its vehicles' Flights (metrics left to the caller), each with the
        group's CPU time in its steps."""
        return [
            logged(flight, simulator, wall_time, self.cpu_time)
            for flight, simulator in zip(self.fleet, self.simulators, strict=True)
        ]


def serve_group(fd: int) -> None:
    """A fleet process's loop (`RemoteGroup`), on the socket `fd`: receives
    its FleetGroup's arguments (the scenario as YAML: Drake's
    SimulatorConfig does not pickle), then answers ("step", t, states,
    until) and ("flights", wall_time)."""
    connection = Connection(fd)
    try:
        scenario_yaml, *group_arguments = connection.recv()
        group = FleetGroup(scenario_from_yaml(scenario_yaml), *group_arguments)
        connection.send(("ok", group.states()))
        while True:
            request = connection.recv()
            if request[0] == "step":
                connection.send(("ok", group.step(*request[1:])))
            else:  # the caller has the scenarios: they do not pickle
                flights = [replace(f, scenario=None) for f in group.flights(request[1])]
                connection.send(("ok", flights))
                return
    except Exception as e:  # raised again in the fleet's process
        try:
            connection.send(("error", e))
        except Exception:  # an exception that does not pickle: its words
            connection.send(("error", RuntimeError(f"{type(e).__name__}: {e}")))


class RemoteGroup:
    """A FleetGroup in a Python process of its own (`serve_group`): Drake's
    objects stay in the process that made them; only states and logs cross
    a socket. A fresh interpreter, not a fork or multiprocessing's spawn,
    which would run the caller's main script again."""

    def __init__(self, scenario: Scenario, *group_arguments):
        ours, theirs = socket.socketpair()
        fd = theirs.fileno()
        serve = (
            f"from mfi_drake.flight.simulation import serve_group; serve_group({fd})"
        )
        # The caller's path, so that a user's field module imports there too.
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        self._process = subprocess.Popen(
            [sys.executable, "-c", serve], pass_fds=[fd], env=env
        )
        theirs.close()
        self._connection = Connection(ours.detach())
        self.send(scenario_to_yaml(scenario), *group_arguments)

    def send(self, *request) -> None:
        self._connection.send(request)

    def receive(self):
        try:
            status, answer = self._connection.recv()
        except EOFError:
            raise RuntimeError("a fleet process ended without answering") from None
        if status == "error":
            raise answer
        return answer

    def close(self) -> None:
        self._connection.close()
        try:
            self._process.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            self._process.kill()


def fly_fleet(
    scenario: Scenario,
    method: "str | Callable | Method",
    until_settled: bool = False,
    stop_at_contact: bool = False,
    processes: int = 1,
) -> Flight:
    """Flies a fleet: every vehicle of `vehicle_scenarios(scenario)` (the
    scenario's own first) with its own Simulator and error control. Every
    h = 1/exchange_hz s of simulated time every vehicle is advanced to that
    time, then the vehicles exchange their positions and velocities: each
    one's input "other_vehicles" is fixed to the others'
    (`systems.exchange.message`), from which it extrapolates them linearly
    until the next exchange. `processes` > 1 spreads the vehicles over that
    many processes (at most one per vehicle), which fly between exchanges
    at once: the same flights, sooner on several cores. Returns the first
    vehicle's Flight with the others in `others`; cpu_time is every
    process's. `stop_at_contact`: the fleet ends at the exchange after a
    vehicle's sphere sensor reads contact with the scene, or at an exchange
    where two vehicles' centres are closer than their two collision radii.
    `until_settled`: it ends once every vehicle has been at rest at its goal
    (`settled_monitor`, checked at the exchanges) for SETTLE_HOLD, where
    nothing but the vehicles moves."""
    count = 1 + len(scenario.other_vehicles)
    if processes < 1:
        raise ValueError(f"processes = {processes}: must be ≥ 1")
    split = np.array_split(np.arange(count), min(processes, count))
    parts = [part.tolist() for part in split]
    arguments = (scenario, method)
    ends = (until_settled, stop_at_contact)
    remote = [RemoteGroup(*arguments, part, *ends) for part in parts[1:]]
    try:
        local = FleetGroup(*arguments, parts[0], *ends)
        radius = local.fleet[0].vehicle.collision_radius
        start, start_cpu = time.perf_counter(), time.process_time()
        states = np.concatenate([local.states(), *(g.receive() for g in remote)])

        def exchange(t: float, until: float | None) -> tuple[bool, bool]:
            """Everyone's step (`FleetGroup.step`), the remote ones at once."""
            nonlocal states
            for group in remote:
                group.send("step", t, states, until)
            answers = [local.step(t, states, until)]
            answers += [group.receive() for group in remote]
            states = np.concatenate([a[0] for a in answers])
            return any(a[1] for a in answers), all(a[2] for a in answers)

        exchange(0.0, None)
        t, k = 0.0, 0
        while t < scenario.duration:
            k += 1
            t_next = min(k / scenario.exchange_hz, scenario.duration)
            ended, at_rest = exchange(t, t_next)
            t = t_next
            touching = centre_gap(states[:, POSITION]) < 2.0 * radius
            if ended or (touching and stop_at_contact) or at_rest:
                break
        wall_time = time.perf_counter() - start
        flights = local.flights(wall_time)
        cpu_time = time.process_time() - start_cpu
        flown = vehicle_scenarios(scenario)
        for group, part in zip(remote, parts[1:], strict=True):
            group.send("flights", wall_time)
            answer = group.receive()
            cpu_time += answer[0].cpu_time  # the group's (`FleetGroup.flights`)
            flights += [
                replace(f, scenario=flown[k]) for f, k in zip(answer, part, strict=True)
            ]
    finally:
        for group in remote:
            group.close()
    for flight in flights:
        flight.cpu_time = cpu_time
    return fleet_flight(flights)


def fleet_flight(flights: list[Flight]) -> Flight:
    """The first vehicle's Flight with the others in `others`, every one
    with its metrics (the first's over the fleet)."""
    for other in flights[1:]:
        other.metrics = flight_metrics(other)
    result = flights[0]
    result.others = flights[1:]
    result.metrics = flight_metrics(result)
    return result


def one_integrator_monitor(
    fleet: OneIntegratorFleet, until_settled: bool, stop_at_contact: bool
):
    """A Simulator monitor: ends the flight at a contact (two vehicles'
    spheres, or a scene sensor's reading, closer than the collision
    radius) with `stop_at_contact`, and once every vehicle has rested at
    its goal for SETTLE_HOLD (`simulation.settled_monitor`'s test) with
    `until_settled`."""
    radius = fleet.vehicle.collision_radius
    n = len(fleet.flown)
    clock = RestClock([s.goal for s in fleet.flown], fleet.scenario.simulator.accuracy)

    def monitor(context) -> EventStatus:
        states = fleet.states.get_output_port(0).Eval(
            fleet.states.GetMyContextFromRoot(context)
        )
        x = states.reshape(n, STATE_SIZE)
        if stop_at_contact:
            if centre_gap(x[:, POSITION]) < 2.0 * radius - CONTACT_MARGIN:
                return EventStatus.ReachedTermination(fleet.chain, "vehicles touch")
            for sensor in fleet.sensors:
                port = sensor.get_output_port(0)
                if in_contact(port.Eval(sensor.GetMyContextFromRoot(context)), radius):
                    return EventStatus.ReachedTermination(sensor, "in contact")
        if until_settled and clock.settled(context.get_time(), x):
            return EventStatus.ReachedTermination(fleet.chain, "every vehicle settled")
        return EventStatus.Succeeded()

    return monitor


def fly_one_integrator(
    scenario: Scenario,
    method: "str | Method" = "mfi",
    until_settled: bool = False,
    stop_at_contact: bool = False,
) -> Flight:
    """Flies a fleet on one integrator (the module docstring). Returns the
    first vehicle's Flight with the others in `others`, each with the
    single-vehicle log layout; wall and CPU times are the fleet's."""
    fleet_diagram = OneIntegratorFleet(scenario, method)
    simulator = simulator_at_start(
        fleet_diagram.diagram, fleet_diagram.plants[0], scenario
    )
    context = simulator.get_mutable_context()
    for plant, flown in zip(
        fleet_diagram.plants[1:], fleet_diagram.flown[1:], strict=True
    ):
        place_at_start(plant, context, flown.start)
    # Only where nothing but the vehicles moves (`settles` without them).
    quiet = until_settled and settles(replace(scenario, other_vehicles=[]))
    if stop_at_contact or quiet:
        simulator.set_monitor(
            one_integrator_monitor(fleet_diagram, quiet, stop_at_contact)
        )
    wall_time, cpu_time = run_timed(simulator, scenario.duration)
    integrator = simulator.get_integrator()
    log = fleet_diagram.logger.FindLog(context)
    times = log.sample_times().copy()
    data = log.data().T.reshape(len(times), len(fleet_diagram.flown), ROW_SIZE)
    slices = row_slices()
    flights = [
        Flight(
            scenario=flown,
            method=fleet_diagram.method,
            sensor="sphere",
            collision_radius=fleet_diagram.vehicle.collision_radius,
            times=times,
            log={name: data[:, k, s] for name, s in slices.items()},
            wall_time=wall_time,
            cpu_time=cpu_time,
            integrator_steps=integrator.get_num_steps_taken(),
            derivative_evaluations=integrator.get_num_derivative_evaluations(),
        )
        for k, flown in enumerate(fleet_diagram.flown)
    ]
    return fleet_flight(flights)


def logged(
    flight: FlightDiagram, simulator: Simulator, wall_time: float, cpu_time: float
) -> Flight:
    """The Flight of a flown diagram (its metrics left to the caller)."""
    context = simulator.get_context()
    integrator = simulator.get_integrator()
    frames = None
    if flight.diagram.HasOutputPort("frames_rendered"):
        port = flight.diagram.GetOutputPort("frames_rendered")
        frames = int(port.Eval(context)[0])
    log = flight.logger.FindLog(context)
    data = log.data().T
    return Flight(
        scenario=flight.scenario,
        method=flight.method,
        sensor="depth" if isinstance(flight.scenario.sensor, Cameras) else "sphere",
        collision_radius=flight.vehicle.collision_radius,
        times=log.sample_times().copy(),
        log={name: data[:, s] for name, s in flight.log_slices().items()},
        wall_time=wall_time,
        cpu_time=cpu_time,
        integrator_steps=integrator.get_num_steps_taken(),
        derivative_evaluations=integrator.get_num_derivative_evaluations(),
        frames_rendered=frames,
    )


def flight_metrics(flight: Flight) -> dict:
    """The run's numbers (docs/usage.md defines each)."""
    scenario = flight.scenario
    times, p = flight.times, flight.positions
    goal = np.asarray(scenario.goal, float)
    error = np.linalg.norm(p - goal, axis=1)
    path_length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    if scenario.obstacles or scenario.ground is not None:
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
        "vehicle": scenario.vehicle,
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
    if flight.others:
        metrics.update(several_vehicles(flight, metrics))
    metrics["outcome"] = outcome(metrics)
    if flight.frames_rendered is not None:
        metrics["frames_rendered"] = flight.frames_rendered
    return metrics
