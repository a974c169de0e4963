"""Big scenes: a world of 1,000 obstacles over a ground, and a scan of
1 million points (docs/big_scenes.md).

    python benchmarks/big_scenes.py [--page docs/big_scenes.md]

Both scenes are generated here, written as a user's files (a scenario
YAML; a binary PLY scan) in a temporary folder, loaded with
`load_scenario` as `mfi-drake run` loads them, and flown with MFI:

- the world: 1,000 boxes, cylinders and spheres of 0.3–0.4 m scattered
  over 40 × 30 × 3 m, a ground at z = 0 (the scene that crashed SceneGraph
  while the ground was a HalfSpace), crossed along y = 15 m; beside it
  the same world with its first 100 obstacles, measured in the same run;
- the scan: 1,000,000 points drawn uniformly on a 30 × 20 × 4 m warehouse
  (floor, walls, 24 shelves), thinned at load to the map voxel (0.05 m by
  default, and 0.1 m); two references, measured in the same run: the
  warehouse flown as its boxes (what the flight costs with SceneGraph's
  sensor), and the scan flight's first seconds with the reading computed
  over every point (`maths.point_maps.map_readings`, the sensor before
  `MapReader`).

Printed for each: the load's wall time and peak memory (tracemalloc:
Python's and numpy's allocations), the flight's real-time factor
(simulated seconds over wall seconds, and over the process's CPU seconds:
the wall-clock factor of an unloaded core, as the machine's other work
slows the wall clock) and outcome. With --page, the table is written
into that page's section big_scenes.
"""

import argparse
import dataclasses
import os
import tempfile
import time
import tracemalloc

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.files import write_section
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.point_clouds import surface_samples, write_ply
from mfi_drake.world.validation import load_scenario

SHAPES = (
    "!Box {size: [0.3, 0.3, 0.3]}",
    "!Cylinder {radius: 0.15, length: 0.4}",
    "!Sphere {radius: 0.2}",
)


def world_yaml(count: int, seed: int = 2) -> str:
    """A scenario of `count` obstacles over 40 × 30 × 3 m and a ground."""
    rng = np.random.default_rng(seed)
    lines = [
        f"name: world_{count}",
        "start: [-2.0, 15.0, 1.5]",
        "goal: [42.0, 15.0, 1.5]",
        "duration: 60.0",
        "ground: {height: 0.0}",
        "obstacles:",
    ]
    for k, p in enumerate(rng.uniform([0, 0, 0], [40, 30, 3], (1000, 3))[:count]):
        position = f"[{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}]"
        lines.append(f"  - {{shape: {SHAPES[k % 3]}, position: {position}}}")
    return "\n".join(lines) + "\n"


def warehouse() -> sc.Scenario:
    """The warehouse's surfaces as obstacles, for `surface_samples`."""
    box = lambda size, at: sc.Obstacle(shape=sc.Box(size=size), position=at)  # noqa: E731
    parts = [
        box([30.0, 20.0, 0.1], [15.0, 10.0, -0.05]),
        box([30.0, 0.1, 4.0], [15.0, -0.05, 2.0]),
        box([30.0, 0.1, 4.0], [15.0, 20.05, 2.0]),
        box([0.1, 20.0, 4.0], [-0.05, 10.0, 2.0]),
        box([0.1, 20.0, 4.0], [30.05, 10.0, 2.0]),
    ]
    for i in range(6):
        for j in range(4):
            parts.append(box([3.0, 0.8, 2.5], [4.0 + 4.5 * i, 3.0 + 4.6 * j, 1.25]))
    return sc.Scenario(obstacles=parts)


def scan_yaml(ply: str, duration: float) -> str:
    return (
        f"name: warehouse_scan\nstart: [1.5, 1.5, 1.2]\ngoal: [28.0, 18.0, 1.5]\n"
        f"duration: {duration}\nworld: {ply}\n"
    )


def measured_load(path: str, overrides=()) -> tuple[sc.Scenario, float, float]:
    """(scenario, load wall time [s], peak traced memory [MB]): the time of
    a load on its own, the memory of a second load under tracemalloc
    (which slows Python's allocations several times)."""
    start = time.perf_counter()
    scenario = load_scenario(path, overrides)
    seconds = time.perf_counter() - start
    tracemalloc.start()
    load_scenario(path, overrides)
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return scenario, seconds, peak


def flown(scenario: sc.Scenario) -> tuple[float, float, str]:
    """(real-time factor by the wall clock, by the process's CPU time,
    outcome) of MFI's flight of `scenario`."""
    cpu = time.process_time()
    flight = simulate(dataclasses.replace(scenario, base_dir=""))
    cpu = time.process_time() - cpu
    m = flight.metrics
    outcome = "reached" if m["reached"] else "not reached"
    outcome += f", {'collided' if m['collided'] else 'no contact'}"
    outcome += f", clearance {m['min_clearance']:.2f} m"
    return m["realtime_factor"], scenario.duration / cpu, outcome


def every_point(scenario: sc.Scenario, seconds: float) -> tuple[float, float, str]:
    """`flown` of the first `seconds` of the flight with the map read over
    every point at every evaluation (`map_readings`)."""
    from mfi_drake.maths import point_maps
    from mfi_drake.systems import point_map

    class EveryPoint:
        def __init__(self, points, radius):
            self._xyz, self._radius = np.ascontiguousarray(points.T), radius

        def __call__(self, p):
            return point_maps.map_readings(self._xyz, p, self._radius)

    kept = point_map.MapReader
    point_map.MapReader = EveryPoint
    try:
        return flown(dataclasses.replace(scenario, duration=seconds))
    finally:
        point_map.MapReader = kept


def row(scene: str, load, factors: tuple[float, float, str]) -> str:
    """A table row: `load` (seconds, peak MB) or None."""
    wall, cpu, outcome = factors
    loaded = f"{load[0]:.2f} | {load[1]:.0f}" if load else " | "
    wall, cpu = (f"{x:.1f}" if x >= 1 else f"{x:.2f}" for x in (wall, cpu))
    return f"| {scene} | {loaded} | {wall}×; {cpu}× | {outcome} |"


def main(argv: list[str] | None = None) -> list[str]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--reference-seconds", type=float, default=2.0)
    parser.add_argument("--page", help="a page to write the table into")
    args = parser.parse_args(argv)
    lines = [
        "| scene | load [s] | peak memory [MB] | real-time factor: wall; CPU "
        "| flight |",
        "|---|---|---|---|---|",
    ]
    print("\n".join(lines), flush=True)

    def add(scene: str, load, factors) -> tuple[float, float, str]:
        lines.append(row(scene, load, factors))
        print(lines[-1], flush=True)
        return factors

    with tempfile.TemporaryDirectory() as folder:
        for count in (100, 1000):
            path = os.path.join(folder, f"world_{count}.yaml")
            with open(path, "w") as f:
                f.write(world_yaml(count))
            scenario, *load = measured_load(path)
            add(f"{count} obstacles and a ground", load, flown(scenario))
        ply = os.path.join(folder, "scan.ply")
        write_ply(ply, surface_samples(warehouse(), args.points, seed=1))
        path = os.path.join(folder, "scan.yaml")
        with open(path, "w") as f:
            f.write(scan_yaml("scan.ply", 60.0))
        scenario, *load = measured_load(path)
        scene = f"scan of {args.points:,} points ({len(scenario.map_points):,} "
        fast = add(scene + "after thinning to 0.05 m)", load, flown(scenario))
        coarse, *load = measured_load(path, [("coarse", "map_voxel: 0.1")])
        scene = f"the same scan thinned to 0.1 m ({len(coarse.map_points):,} points)"
        add(scene, load, flown(coarse))
        boxes = dataclasses.replace(
            scenario, map_points=[], obstacles=warehouse().obstacles
        )
        add(
            "the same warehouse as its 29 boxes (SceneGraph's sensor)",
            None,
            flown(boxes),
        )
        slow = every_point(scenario, args.reference_seconds)
        scene = (
            f"the scan read over every point, first {args.reference_seconds:g} s "
            f"(CPU: {fast[1] / slow[1]:.0f}× slower than `MapReader`)"
        )
        add(scene, None, slow)
    if args.page:
        write_section(args.page, "big_scenes", "\n".join(lines))
    return lines


if __name__ == "__main__":
    main()
