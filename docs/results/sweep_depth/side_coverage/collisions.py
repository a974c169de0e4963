"""Where each collision of a training sweep comes from (docs/depth_camera.md,
"Side coverage").

    cd docs/results/sweep_depth/side_coverage
    python collisions.py SEED DENSITY OVERRIDE.yaml I,J,...

Flies field I of SEED at DENSITY with the override file layered on, as the
sweep flies it (one AdvanceTo), with a monitor that records the camera's
percept at every step and ends the flight at contact. For the obstacle hit it
prints: when its surface first entered the memory (a remembered sample
within 5 cm of it), when a reading first lay on it (within 5 cm), how long it
has been read without a break before contact, and for how long in the last
second it was among the 3 truly nearest obstacles (SceneGraph's distances,
within 1 m) without being read.
"""

import dataclasses
import sys

import numpy as np
from pydrake.systems.framework import EventStatus

from mfi_drake.config.scenario import DepthCamera
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulation import simulator_at_start
from mfi_drake.maths.layout import OBSTACLE_COUNT, READING_SIZE
from mfi_drake.studies.sweep import with_overrides
from mfi_drake.world import generator
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.reference_path import Clearance

SAMPLE = 0.01  # s between the recorded steps examined


def fly_to_contact(scenario):
    """The flight's recorded steps (t, state, percept, reading signal) up to
    contact or the end."""
    whole = Clearance(scenario, VEHICLES[scenario.vehicle].collision_radius)
    built = build_diagram(scenario)
    simulator = simulator_at_start(built.diagram, built.plant, scenario)
    steps = []

    def monitor(root):
        sensor = built.sensor.GetMyContextFromRoot(root)
        plant = built.plant.GetMyContextFromRoot(root)
        x = plant.get_continuous_state_vector().CopyToVector()
        signal = built.sensor.GetOutputPort("obstacle").Eval(sensor).copy()
        steps.append((root.get_time(), x, built.sensor.percept(sensor), signal))
        if whole.closest(x[:3], 0.5)[0] < 0:
            return EventStatus.ReachedTermination(built.diagram, "contact")
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    simulator.Initialize()
    simulator.AdvanceTo(scenario.duration)
    contact = whole.closest(steps[-1][1][:3], 0.5)[0] < 0
    return steps, contact


def on(obstacle, points) -> bool:
    """Whether any of `points` lies within 5 cm of `obstacle`'s surface."""
    return len(points) > 0 and min(obstacle_distances(obstacle, points, 0.1)) < 0.05


def main() -> None:
    seed, density, override = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
    with open(override) as f:
        text = f.read()
    for index in (int(i) for i in sys.argv[4].split(",")):
        field = generator.random_field(seed, index, density, sensor=DepthCamera())
        scenario = with_overrides(field, [(override, text)])
        steps, contact = fly_to_contact(scenario)
        if not contact:
            print(f"field {index}: no contact", flush=True)
            continue
        radius = VEHICLES[scenario.vehicle].collision_radius
        singles = [
            dataclasses.replace(scenario, obstacles=[o]) for o in scenario.obstacles
        ]
        t, x = steps[-1][0], steps[-1][1]
        hit = int(np.argmin([obstacle_distances(s, [x[:3]])[0] for s in singles]))
        first_seen = first_read = last_unread = None
        unread, previous = 0.0, 0.0
        for time, state, percept, signal in steps:
            if time - previous < SAMPLE and time != t:
                continue
            dt, previous, p = time - previous, time, state[:3]
            if first_seen is None and on(singles[hit], percept.memory.points):
                first_seen = time
            readings = [
                p + signal[READING_SIZE * i : READING_SIZE * i + 3]
                for i in range(OBSTACLE_COUNT)
                if signal[READING_SIZE * i + 3]
            ]
            read = on(singles[hit], readings)
            if read and first_read is None:
                first_read = time
            if not read:
                last_unread = time
                if time > t - 1.0:
                    d = np.array([obstacle_distances(s, [p], 1.5)[0] for s in singles])
                    if d[hit] < 1.0 + radius and np.sum(d < d[hit]) < 3:
                        unread += dt
        seen = "never" if first_seen is None else f"from {t - first_seen:.2f} s before"
        read = "never" if first_read is None else f"{t - first_read:.2f} s before"
        print(
            f"field {index}: contact t={t:.2f} s at {np.linalg.norm(x[6:9]):.2f} m/s "
            f"with obstacle {hit}; in memory {seen}; first read {read}; read "
            f"without a break for the last {t - (last_unread or 0.0):.2f} s; in the "
            f"last 1 s among the 3 nearest within 1 m but not read for {unread:.2f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
