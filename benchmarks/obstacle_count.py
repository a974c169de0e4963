"""Cost of one flight with 10, 100 and 1000 obstacles in the world.

    python benchmarks/obstacle_count.py [--counts 10 100 1000] [--repeats 3]

The flight is MFI on a random field of 10 obstacles around the start–goal
line (`generator`, density 0.05). The larger worlds add random obstacles of
every kind whose centres are more than 12 m from that line, beyond the
sphere sensor's 3 m plus any obstacle's size plus the flight's detours: the
vehicle never senses them, so every world flies the same trajectory (checked)
and only the cost of carrying the obstacles shows. Printed, best of
--repeats, measured in this one run:

- build: `build_diagram` (registering the obstacles with SceneGraph);
- simulate: Initialize + AdvanceTo, where the sensor queries SceneGraph
  with a threshold of r_s (its broadphase skips far obstacles);
- metrics: `flight_metrics`, whose clearance asks for the exact distance to
  every obstacle at every logged step.

The machine has 2 cores shared with other work: single runs are noisy,
hence the best of several repeats.
"""

import argparse
import dataclasses
import time

import numpy as np

from mfi_drake.flight.diagram import build_diagram
from mfi_drake.flight.simulator import fly
from mfi_drake.world.generator import DEFAULT_WORKSPACE, random_field, random_obstacle

FAR = 12.0  # m, least distance of an added obstacle's centre from the line


def far_obstacles(count: int, seed: int = 0) -> list:
    """`count` random obstacles in a 240 × 240 × 60 m box, none within FAR of
    the start–goal line."""
    rng = np.random.default_rng(seed)
    start = np.asarray(DEFAULT_WORKSPACE.start)
    goal = np.asarray(DEFAULT_WORKSPACE.goal)
    low, high = np.array([-115.0, -120.0, -28.0]), np.array([125.0, 120.0, 32.0])
    out = []
    while len(out) < count:
        obstacle = random_obstacle(rng, low, high)
        p = np.asarray(obstacle.position)
        t = np.clip(np.dot(p - start, goal - start) / np.sum((goal - start) ** 2), 0, 1)
        if np.linalg.norm(p - (start + t * (goal - start))) > FAR:
            out.append(obstacle)
    return out


def cost(scenario, repeats: int) -> dict:
    """Best-of-`repeats` wall times [s] of build, simulate and metrics."""
    best = {"build": np.inf, "simulate": np.inf, "metrics": np.inf}
    for _ in range(repeats):
        start = time.perf_counter()
        diagram = build_diagram(scenario)
        built = time.perf_counter()
        flight = fly(diagram)
        done = time.perf_counter()
        best["build"] = min(best["build"], built - start)
        best["simulate"] = min(best["simulate"], flight.wall_time)
        best["metrics"] = min(best["metrics"], done - built - flight.wall_time)
    return best | {
        "steps": flight.metrics["steps"],
        "path_length": flight.metrics["path_length"],
    }


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--duration", type=float, default=30.0, help="simulated s")
    args = parser.parse_args(argv)
    if min(args.counts) < 10 or args.repeats < 1 or args.duration <= 0:
        parser.error("--counts must be ≥ 10, --repeats ≥ 1, --duration > 0")
    results = {}
    near = random_field(2, 0, 0.05, duration=args.duration)
    far = far_obstacles(max(args.counts) - len(near.obstacles))
    print(
        f"MFI, {len(near.obstacles)} obstacles near the line, "
        f"{args.duration:g} s simulated, best of {args.repeats}"
    )
    print("obstacles | build [s] | simulate [s] | metrics [s] | steps | path [m]")
    for count in args.counts:
        extra = far[: count - len(near.obstacles)]
        world = dataclasses.replace(near, obstacles=near.obstacles + extra)
        r = results[count] = cost(world, args.repeats)
        print(
            f"{count:9d} | {r['build']:9.3f} | {r['simulate']:12.3f} | "
            f"{r['metrics']:11.3f} | {r['steps']:5d} | {r['path_length']:.4f}"
        )
    lengths = {r["path_length"] for r in results.values()}
    print(
        "same trajectory in every world: "
        + ("yes" if max(lengths) - min(lengths) < 1e-9 else "NO")
    )
    low, high = min(args.counts), max(args.counts)
    print(
        f"simulate cost ×{results[high]['simulate'] / results[low]['simulate']:.2f} "
        f"from {low} to {high} obstacles; build ×"
        f"{results[high]['build'] / results[low]['build']:.1f}, metrics ×"
        f"{results[high]['metrics'] / results[low]['metrics']:.1f}"
    )
    return results


if __name__ == "__main__":
    main()
