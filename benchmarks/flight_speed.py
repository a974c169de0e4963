"""How fast the planar wall flight runs, next to a C++-only reference.

    python benchmarks/flight_speed.py [--repeats 5] [--duration SECONDS]

Prints, all measured in this one run:

- the MFI flight of scenarios/planar_wall.yaml, the diagram `mfi-drake run`
  flies (`simulation.simulate`): wall time and process CPU time of
  Initialize + AdvanceTo, each the best of --repeats, their real-time
  factors, integrator steps and time-derivative evaluations per step;
- the reference: Drake's C++ `QuadrotorPlant` (the same vehicle) closed by
  Drake's C++ `StabilizingLQRController` with its set point at the
  scenario's start, started there at rest, logging its state at every step
  like the MFI diagram, simulated for the same duration with the same
  SimulatorConfig. It hovers: an LQR set at the goal, 8 m away, commands
  tilts its linearisation cannot handle and tumbles into gimbal lock.
  Hovering is no idle run for the integrator: the LQR's fast attitude poles
  keep the error-controlled RK3 at short steps (about 2200 in 40 s);
- the ratio of the two real-time factors, and of the cost of one
  derivative evaluation.

Single-threaded like every Drake simulation. The machine's other load shows
up in the wall time, hence the best of several repeats and the CPU time
beside it.
"""

import argparse
import dataclasses
import os

import numpy as np
from pydrake.examples import StabilizingLQRController
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import make_plant
from mfi_drake.flight.simulation import Flight, run_timed, simulate, simulator_at_start
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PLANAR_WALL = os.path.join(ROOT, "scenarios", "planar_wall.yaml")


@dataclasses.dataclass
class Run:
    """A timed simulation: the best wall and CPU times over the repeats."""

    sim_time: float
    wall_time: float
    cpu_time: float
    steps: int
    derivative_evaluations: int

    @property
    def realtime_factor(self) -> float:
        return self.sim_time / self.wall_time

    @property
    def cpu_realtime_factor(self) -> float:
        return self.sim_time / self.cpu_time

    @property
    def evaluations_per_step(self) -> float:
        return self.derivative_evaluations / self.steps

    @property
    def microseconds_per_evaluation(self) -> float:
        """Wall time per derivative evaluation (everything else included)."""
        return 1e6 * self.wall_time / self.derivative_evaluations


def time_mfi(scenario: Scenario, repeats: int) -> tuple[Run, Flight]:
    """The MFI flight, flown `repeats` times; its best times and the flight."""
    flights = [simulate(scenario) for _ in range(repeats)]
    best = min(flights, key=lambda flight: flight.wall_time)
    run = Run(
        sim_time=best.metrics["sim_time"],
        wall_time=best.wall_time,
        cpu_time=min(flight.cpu_time for flight in flights),
        steps=best.integrator_steps,
        derivative_evaluations=best.derivative_evaluations,
    )
    return run, best


def time_lqr_reference(scenario: Scenario, repeats: int) -> tuple[Run, np.ndarray]:
    """QuadrotorPlant + StabilizingLQRController hovering at scenario.start;
    its best times and its final state."""
    runs = []
    for _ in range(repeats):
        builder = DiagramBuilder()
        plant = builder.AddSystem(make_plant(VEHICLES[scenario.vehicle]))
        controller = builder.AddSystem(
            StabilizingLQRController(plant, np.asarray(scenario.start, float))
        )
        builder.Connect(plant.get_output_port(0), controller.get_input_port())
        builder.Connect(controller.get_output_port(), plant.get_input_port(0))
        logger = LogVectorOutput(plant.get_output_port(0), builder, publish_period=0.0)
        simulator = simulator_at_start(builder.Build(), plant, scenario)
        context = simulator.get_mutable_context()
        wall_time, cpu_time = run_timed(simulator, scenario.duration)
        integrator = simulator.get_integrator()
        run = Run(
            sim_time=context.get_time(),
            wall_time=wall_time,
            cpu_time=cpu_time,
            steps=integrator.get_num_steps_taken(),
            derivative_evaluations=integrator.get_num_derivative_evaluations(),
        )
        runs.append((run, logger.FindLog(context).data()[:, -1].copy()))
    best, final_state = min(runs, key=lambda pair: pair[0].wall_time)
    best.cpu_time = min(run.cpu_time for run, _ in runs)
    return best, final_state


def describe(run: Run) -> str:
    return (
        f"{run.sim_time:.1f} s simulated in {run.wall_time:.4f} s wall = "
        f"{run.realtime_factor:.1f}x real time (CPU {run.cpu_time:.4f} s = "
        f"{run.cpu_realtime_factor:.1f}x); {run.steps} steps, "
        f"{run.derivative_evaluations} derivative evaluations "
        f"({run.evaluations_per_step:.2f} per step, "
        f"{run.microseconds_per_evaluation:.1f} us each)"
    )


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=PLANAR_WALL)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--duration", type=float, help="override the scenario's duration [s]"
    )
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats = {args.repeats}: must be >= 1")
    scenario = load_scenario(args.scenario)
    if args.duration is not None:
        if not args.duration > 0.0:
            parser.error(f"--duration = {args.duration}: must be > 0")
        scenario = dataclasses.replace(scenario, duration=args.duration)

    mfi, flight = time_mfi(scenario, args.repeats)
    lqr, lqr_final = time_lqr_reference(scenario, args.repeats)
    m = flight.metrics
    print(f"best of {args.repeats} repeats, scenario {scenario.name}")
    print(f"MFI flight (Python LeafSystems): {describe(mfi)}")
    print(
        f"  outcome: success {m['success']}, min clearance "
        f"{m['min_clearance']:.3f} m, path {m['path_length']:.2f} m, "
        f"{m['steps']} logged samples"
    )
    print(f"LQR reference (C++ QuadrotorPlant + LQR, hovering): {describe(lqr)}")
    drift = float(np.linalg.norm(lqr_final[0:3] - np.asarray(scenario.start)))
    print(f"  outcome: final distance from its set point {drift:.2e} m")
    ratio = mfi.realtime_factor / lqr.realtime_factor
    cpu_ratio = mfi.cpu_realtime_factor / lqr.cpu_realtime_factor
    cost_ratio = mfi.microseconds_per_evaluation / lqr.microseconds_per_evaluation
    print(
        f"ratio of real-time factors, MFI / LQR reference: {ratio:.4f} wall, "
        f"{cpu_ratio:.4f} CPU (the reference runs {1 / ratio:.1f}x faster; one "
        f"MFI derivative evaluation costs {cost_ratio:.1f}x one of the reference)"
    )
    return {"mfi": mfi, "lqr": lqr, "ratio": ratio, "flight": flight}


if __name__ == "__main__":
    main()
