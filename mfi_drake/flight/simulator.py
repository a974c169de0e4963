"""One vehicle's diagram flown on one Drake Simulator: `simulator_at_start`
(the scenario's SimulatorConfig, the vehicle at its start), `start_simulator`
(with the monitors of `fly`), `run_timed`, `logged` (the Flight of a flown
diagram) and `fly`, all four in turn."""

import time

from pydrake.systems.analysis import Simulator

from mfi_drake.config.scenario import Cameras, Scenario
from mfi_drake.flight.builder import apply_simulator_config, place_quadrotor
from mfi_drake.flight.diagram import FlightDiagram
from mfi_drake.flight.monitors import (
    contact_monitor,
    first_of,
    settled_monitor,
    settles,
)
from mfi_drake.flight.result import Flight, flight_metrics


def simulator_at_start(diagram, plant, scenario: Scenario) -> Simulator:
    """A Simulator of `diagram` with the scenario's SimulatorConfig (and the
    context accuracy eq 21's witnesses read, `apply_simulator_config`), the
    QuadrotorPlant `plant` (a subsystem of `diagram`) at the scenario's
    start, at rest."""
    simulator = Simulator(diagram)
    apply_simulator_config(scenario.simulator, simulator)
    place_quadrotor(plant, simulator.get_mutable_context(), scenario.start)
    return simulator


def run_timed(simulator: Simulator, duration: float) -> tuple[float, float]:
    """Initialize + AdvanceTo(duration); (wall time, process CPU time) [s]."""
    start, start_cpu = time.perf_counter(), time.process_time()
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return time.perf_counter() - start, time.process_time() - start_cpu


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
    end it when a sphere sensor reads contact (`contact_monitor`)."""
    simulator = start_simulator(flight, until_settled, stop_at_contact)
    wall_time, cpu_time = run_timed(simulator, flight.scenario.duration)
    result = logged(flight, simulator, wall_time, cpu_time)
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
