"""One vehicle's diagram flown on one Drake Simulator: `simulator_at_start`
(the scenario's SimulatorConfig, the vehicle at its start), `start_simulator`
(with the monitors of `fly`), `advance_timed` (`run_timed` without the
status), `logged` (the Flight of a flown diagram) and `fly`, all four in
turn."""

import time
from typing import NamedTuple

from pydrake.systems.analysis import Simulator, SimulatorStatus

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.sensors import Cameras
from mfi_drake.flight.builder import apply_simulator_config, place_quadrotor
from mfi_drake.flight.diagram import FlightDiagram
from mfi_drake.flight.monitors import (
    contact_monitor,
    first_of,
    settled_monitor,
    settles,
)
from mfi_drake.flight.result import Flight, flight_metrics
from mfi_drake.systems.escape import TRAPPED_MESSAGE


def simulator_at_start(diagram, plant, scenario: Scenario) -> Simulator:
    """A Simulator of `diagram` with the scenario's SimulatorConfig (and the
    context accuracy eq 21's witnesses read, `apply_simulator_config`), the
    QuadrotorPlant `plant` (a subsystem of `diagram`) at the scenario's
    start, at rest."""
    simulator = Simulator(diagram)
    apply_simulator_config(scenario.simulator, simulator)
    place_quadrotor(plant, simulator.get_mutable_context(), scenario.start)
    return simulator


class TimedRun(NamedTuple):
    wall_time: float  # [s]
    cpu_time: float  # process CPU time [s]
    status: SimulatorStatus  # AdvanceTo's: why the flight ended


def advance_timed(simulator: Simulator, duration: float) -> TimedRun:
    """Initialize + AdvanceTo(duration), timed."""
    start, start_cpu = time.perf_counter(), time.process_time()
    simulator.Initialize()
    status = simulator.AdvanceTo(duration)
    return TimedRun(
        time.perf_counter() - start, time.process_time() - start_cpu, status
    )


def run_timed(simulator: Simulator, duration: float) -> tuple[float, float]:
    """(wall time, process CPU time) [s] of `advance_timed`."""
    return advance_timed(simulator, duration)[:2]


def ended_trapped(status: SimulatorStatus) -> bool:
    """Whether the escape rule ended the flight: it ran out of options
    (`EscapeNavigator`), the goal cannot be reached."""
    reason = SimulatorStatus.ReturnReason.kReachedTerminationCondition
    return status.reason() == reason and status.message() == TRAPPED_MESSAGE


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
        simulator.set_monitor(first_of(monitors))
    return simulator


def fly(
    flight: FlightDiagram, until_settled: bool = False, stop_at_contact: bool = False
) -> Flight:
    """Simulates an already built diagram from the scenario's start at rest.
    `until_settled`: end the flight once the vehicle rests at its goal
    (`settled_monitor`), where the scenario `settles`. `stop_at_contact`:
    end it when a sphere sensor reads contact (`contact_monitor`). A
    flight the escape rule ended is `trapped` (`ended_trapped`)."""
    simulator = start_simulator(flight, until_settled, stop_at_contact)
    run = advance_timed(simulator, flight.scenario.duration)
    result = logged(flight, simulator, run.wall_time, run.cpu_time)
    result.trapped = ended_trapped(run.status)
    result.metrics = flight_metrics(result)
    return result


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
