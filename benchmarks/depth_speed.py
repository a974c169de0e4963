"""How fast the depth-camera flights of paper Fig 11 run.

    python benchmarks/depth_speed.py [--repeats 3]

For scenarios/pelican_cylinder.yaml and pelican_cube.yaml, flown as
`mfi-drake run` flies them (`simulation.simulate`), prints the best wall
time of Initialize + AdvanceTo over --repeats and its real-time factor, the
best process CPU time of the whole `simulate` call (building the diagram and
the metrics included, so an upper bound on the flight's) and its real-time
factor, the frames the camera rendered and the integrator steps; then the
same flight with the sphere sensor (radius = the camera's max_range)
instead, so the camera's share of the cost shows. The machine's other load
shows up in the wall time as noise, hence the best of several runs and the
CPU time beside it.
"""

import argparse
import dataclasses
import os
import time

from mfi_drake.config.scenario import Scenario, SphereSensor
from mfi_drake.flight.simulation import Flight, simulate
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIOS = ["pelican_cylinder.yaml", "pelican_cube.yaml"]


def best_of(scenario: Scenario, repeats: int) -> tuple[Flight, float]:
    """The flight with the smallest wall time of `repeats` runs, and the
    smallest CPU time [s] of their `simulate` calls."""
    flights, cpu = [], []
    for _ in range(repeats):
        start = time.process_time()
        flights.append(simulate(scenario))
        cpu.append(time.process_time() - start)
    return min(flights, key=lambda f: f.wall_time), min(cpu)


def line(label: str, flight: Flight, cpu: float) -> str:
    m = flight.metrics
    frames = m.get("frames_rendered")
    return (
        f"  {label:<7} {m['sim_time']:4.1f} s simulated: wall {m['wall_time']:5.2f} s "
        f"= {m['realtime_factor']:5.1f}x real time, CPU {cpu:5.2f} s "
        f"= {m['sim_time'] / cpu:5.1f}x, "
        f"{'-' if frames is None else frames} frames, {m['steps']} steps, "
        f"{'success' if m['success'] else 'FAILED'}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats = {args.repeats}: must be >= 1")
    for name in SCENARIOS:
        scenario = load_scenario(os.path.join(ROOT, "scenarios", name))
        camera = scenario.sensor
        print(
            f"{scenario.name}: depth camera {camera.width}x{camera.height}, "
            f"{camera.rate_hz:g} frames/s (best of {args.repeats})"
        )
        print(line("depth", *best_of(scenario, args.repeats)))
        sphere = dataclasses.replace(
            scenario, sensor=SphereSensor(radius=camera.max_range)
        )
        print(line("sphere", *best_of(sphere, args.repeats)))


if __name__ == "__main__":
    main()
