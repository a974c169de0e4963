"""Point-cloud maps: writes the shipped map and measures a big one.

    python benchmarks/point_map.py            # writes scenarios/maps/planar_wall.ply
    python benchmarks/point_map.py --measure  # and loads/flies a 1e6-point map

The shipped map is scenarios/planar_wall.yaml's wall as a scanner would
record it: MAP_POINTS points drawn uniformly on its surfaces (seed 0,
`world.point_clouds.surface_samples`), a binary PLY of float32. With
`--measure`, the same wall sampled with 1e6 points is written to a
temporary PLY, loaded as a scenario (`load_scenario`: read, checked,
thinned to `map_voxel`) and flown; the load's wall time and peak memory
(tracemalloc: numpy's allocations) and the flight's outcome are printed.
"""

import argparse
import dataclasses
import os
import tempfile
import time
import tracemalloc

from mfi_drake.world.point_clouds import surface_samples, write_ply
from mfi_drake.world.validation import load_scenario

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenarios")
MAP_POINTS = 4000


def write_shipped_map() -> str:
    """Writes scenarios/maps/planar_wall.ply; returns its path."""
    wall = load_scenario(os.path.join(ROOT, "planar_wall.yaml"))
    path = os.path.join(ROOT, "maps", "planar_wall.ply")
    write_ply(path, surface_samples(wall, MAP_POINTS, seed=0))
    return path


def measure(points: int = 1_000_000) -> None:
    from mfi_drake.flight.simulation import simulate

    wall = load_scenario(os.path.join(ROOT, "planar_wall.yaml"))
    with tempfile.TemporaryDirectory() as folder:
        write_ply(os.path.join(folder, "big.ply"), surface_samples(wall, points))
        scenario_path = os.path.join(folder, "big.yaml")
        with open(os.path.join(ROOT, "planar_wall_map.yaml")) as f:
            text = f.read().replace("maps/planar_wall.ply", "big.ply")
        with open(scenario_path, "w") as f:
            f.write(text)
        tracemalloc.start()
        start = time.perf_counter()
        scenario = load_scenario(scenario_path)
        load = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    print(
        f"{points} points: loaded in {load:.2f} s, peak {peak / 1e6:.0f} MB, "
        f"{len(scenario.map_points)} points after thinning to {scenario.map_voxel} m"
    )
    start = time.perf_counter()
    flight = simulate(dataclasses.replace(scenario, base_dir=""))
    m = flight.metrics
    print(
        f"flown in {time.perf_counter() - start:.1f} s: reached {m['reached']}, "
        f"collided {m['collided']}, min clearance {m['min_clearance']:.3f} m"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--measure", action="store_true")
    args = parser.parse_args()
    print("wrote", write_shipped_map())
    if args.measure:
        measure()
