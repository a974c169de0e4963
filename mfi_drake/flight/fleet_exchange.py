"""A fleet flown by exchange (`fleet_integration: exchange`, docs/fleets.md):
one diagram and Simulator a vehicle, the vehicles exchanging their states
every 1/exchange_hz s (`fly_fleet`), in this process (`FleetGroup`) or
spread over several (`RemoteGroup`, each serving a FleetGroup with
`serve_group`)."""

import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from multiprocessing.connection import Connection

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.scenario_yaml import scenario_from_yaml, scenario_to_yaml
from mfi_drake.flight.diagram import build_diagram, vehicle_scenarios
from mfi_drake.flight.methods import Method
from mfi_drake.flight.monitors import RESTING, centre_gap, settled_monitor, settles
from mfi_drake.flight.result import Flight, fleet_flight
from mfi_drake.flight.simulator import ended_trapped, logged, start_simulator
from mfi_drake.maths.layout import POSITION, VELOCITY
from mfi_drake.systems.exchange import message


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
        self.trapped = [False] * len(self.fleet)  # `ended_trapped`, each
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
        for i, simulator in enumerate(self.simulators):
            if until is None:
                simulator.Initialize()
            else:
                self.trapped[i] = ended_trapped(simulator.AdvanceTo(until))
        ended = until is not None and any(c.get_time() < until for c in self.contexts)
        # A list, not a generator: every monitor must see every exchange.
        resting = [m(c).severity() == RESTING for m, c in self.settled]
        at_rest = bool(resting) and all(resting)
        self.cpu_time += time.process_time() - start
        return self.states(), ended, at_rest

    def flights(self, wall_time: float) -> list[Flight]:
        """Its vehicles' Flights (metrics left to the caller), each with the
        group's CPU time in its steps."""
        flights = []
        for flight, simulator, trapped in zip(
            self.fleet, self.simulators, self.trapped, strict=True
        ):
            flights.append(logged(flight, simulator, wall_time, self.cpu_time))
            flights[-1].trapped = trapped
        return flights


def serve_group(fd: int) -> None:
    """A fleet process's loop (`RemoteGroup`), on the socket `fd`: receives
    its FleetGroup's arguments (the scenario as YAML, Drake's
    SimulatorConfig does not pickle, and its base_dir), then answers ("step", t, states,
    until) and ("flights", wall_time)."""
    connection = Connection(fd)
    try:
        scenario_yaml, base_dir, *group_arguments = connection.recv()
        scenario = scenario_from_yaml(scenario_yaml, base_dir)
        group = FleetGroup(scenario, *group_arguments)
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
            "from mfi_drake.flight.fleet_exchange import serve_group; "
            f"serve_group({fd})"
        )
        # The caller's path, so that a user's field module imports there too.
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
        self._process = subprocess.Popen(
            [sys.executable, "-c", serve], pass_fds=[fd], env=env
        )
        theirs.close()
        self._connection = Connection(ours.detach())
        self.send(scenario_to_yaml(scenario), scenario.base_dir, *group_arguments)

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
    A vehicle the escape rule ends (`ended_trapped`) ends the fleet at that
    exchange.
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
