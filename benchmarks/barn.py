"""BARN worlds (the BARN challenge's 300 Gazebo worlds of cylinders,
Perille et al., SSRR 2020) as scenarios, their feasibility, and flights.

    python benchmarks/barn.py WORLDS_DIR --worlds 1 3 5 [--methods mfi,gf]
                              [--out out/barn] [--write-scenarios]
                              [--readings N] [--engine systems]
                              [--set YAML ...] [--override FILE ...]

WORLDS_DIR holds the benchmark's world_N.world files (jackal_helper/worlds/
BARN in the challenge's repository; not part of this project). For each
index N of --worlds:

- conversion (`barn_scenario`): every model whose collision geometry is a
  cylinder becomes a cylinder obstacle at its pose (BARN's: radius
  0.075 m, length 1 m, centred at z = 0). The drake_default quadcopter
  flies at the cylinders' mid-height (z = 0) in the 1 m slab between a
  floor box (top face at z = -0.5) and a ceiling box (bottom at +0.5) that
  cover the whole map, so it can neither pass over nor under. Start and
  goal are the benchmark's (run.py: INIT_POSITION (-2.25, 3), the goal
  (0, 10) from it), the limit its 100 s. The goal tolerance stays this
  project's 0.1 m (BARN counts 1 m).
- feasibility (`widest_passage`): the largest radius r of a disc that can
  move from start to goal among the cylinders, by a grid search: the map
  rasterised at `CELL` (0.02 m) over the cylinders' extent plus a margin,
  a cell free for radius r where its centre is more than r + 0.075 m from
  every cylinder's axis, passable where the start's cell and the goal's
  lie in one 8-connected component of free cells (scipy's
  `ndimage.label`); r bisected from [0, 1] m to below `CELL`. A world is
  feasible for the vehicle where r ≥ its collision radius (0.225 m). Only
  cell centres are tested, so r is good to about a cell's half-diagonal
  (0.014 m) either way.
- flights: each method of --methods, `simulate` on the compiled engine
  (--engine; the engines fly the same flights, benchmarks/engines.py),
  the sphere sensor reporting --readings obstacles (default 3), with the
  scenario fields of each --set and --override layered on in order, as
  `mfi-drake run` layers them (e.g. --set 'escape: {door_brake: true}').

Prints one line a world and method and the table of success, collision and
timeout per method (feasible worlds only counted as reachable); writes
DIR/barn.jsonl and DIR/barn.md (and DIR/world_N.yaml with
--write-scenarios). BARN's odd-indexed worlds are for development, the even
ones held out (issue 50).
"""

import argparse
import collections
import json
import os
import xml.etree.ElementTree as ET

import numpy as np
from scipy import ndimage

from mfi_drake.app.arguments import add_overrides, overrides
from mfi_drake.config import scenario as sc
from mfi_drake.config.scenario import ENGINES, ScenarioError
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.files import write_text
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.variants import with_overrides
from mfi_drake.world.generator import write_scenario
from mfi_drake.world.nonconvex import THICKNESS, box

START = (-2.25, 3.0)  # run.py's INIT_POSITION for worlds 0-299
GOAL = (START[0], START[1] + 10.0)  # run.py's GOAL_POSITION, from the start
DURATION = 100.0  # s, run.py's limit
SLAB = 1.0  # m, the cylinders' length: floor and ceiling close it
CELL = 0.02  # m, the feasibility grid
MARGIN = 1.0  # m of grid round the cylinders, start and goal


def cylinders(path: str) -> np.ndarray:
    """(k, 3): x, y and radius of every model's cylinder collision in the
    Gazebo world file `path` (the model's pose; BARN's links sit at it)."""
    out = []
    for model in ET.parse(path).getroot().iter("model"):
        cylinder = model.find("link/collision/geometry/cylinder")
        pose = model.find("pose")
        if cylinder is None or pose is None:
            continue
        x, y = (float(v) for v in pose.text.split()[:2])
        out.append((x, y, float(cylinder.find("radius").text)))
    return np.array(out).reshape(-1, 3)


def barn_scenario(path: str, name: str) -> sc.Scenario:
    """The BARN world file `path` as a scenario (the module docstring)."""
    posts = cylinders(path)
    obstacles = [
        sc.Obstacle(
            shape=sc.Cylinder(radius=float(r), length=SLAB),
            position=[float(x), float(y), 0.0],
        )
        for x, y, r in posts
    ]
    lo = np.minimum(posts[:, :2].min(axis=0), np.minimum(START, GOAL)) - MARGIN
    hi = np.maximum(posts[:, :2].max(axis=0), np.maximum(START, GOAL)) + MARGIN
    middle, size = (lo + hi) / 2, hi - lo
    for z in (-(SLAB + THICKNESS) / 2, (SLAB + THICKNESS) / 2):
        obstacles.append(box([*middle, z], [*size, THICKNESS]))
    return sc.Scenario(
        name=name,
        start=[*START, 0.0],
        goal=[*GOAL, 0.0],
        duration=DURATION,
        obstacles=obstacles,
    )


def _reachable(free: np.ndarray, start, goal) -> bool:
    """Whether the cells `start` and `goal` lie in one 8-connected
    component of the True cells of `free`."""
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    return bool(free[start] and labels[start] == labels[goal])


def widest_passage(posts: np.ndarray) -> float:
    """The largest disc radius (to CELL) that passes from START to GOAL
    among the cylinders `posts` (k, 3) (the module docstring)."""
    lo = np.minimum(posts[:, :2].min(axis=0), np.minimum(START, GOAL)) - MARGIN
    hi = np.maximum(posts[:, :2].max(axis=0), np.maximum(START, GOAL)) + MARGIN
    xs, ys = np.arange(lo[0], hi[0], CELL), np.arange(lo[1], hi[1], CELL)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    # Each cell's clearance to the nearest cylinder's surface.
    clearance = np.full(gx.shape, np.inf)
    for x, y, r in posts:
        clearance = np.minimum(clearance, np.hypot(gx - x, gy - y) - r)

    def cell(point):
        return (
            int(round((point[0] - lo[0]) / CELL)),
            int(round((point[1] - lo[1]) / CELL)),
        )

    start, goal = cell(START), cell(GOAL)
    low, high = 0.0, 1.0
    while high - low > CELL:
        mid = (low + high) / 2
        if _reachable(clearance > mid, start, goal):
            low = mid
        else:
            high = mid
    return low


def table(records: list[dict], methods: list[str]) -> str:
    """Success, collision and timeout per method (markdown)."""
    lines = [
        "| method | success | collision | timeout | trapped | worlds |",
        "|---|---|---|---|---|---|",
    ]
    for method in methods:
        mine = [r for r in records if r["method"] == method]
        count = collections.Counter(r["outcome"] for r in mine)
        lines.append(
            f"| `{method}` | {count['success']} | {count['collision']} | "
            f"{count['timeout']} | {count['trapped']} | {len(mine)} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("worlds_dir")
    parser.add_argument("--worlds", type=int, nargs="+", required=True)
    parser.add_argument("--methods", default="mfi,gf,mfi-memoryless")
    parser.add_argument("--out", default="out/barn")
    parser.add_argument("--engine", default="compiled", choices=ENGINES)
    parser.add_argument("--write-scenarios", action="store_true")
    parser.add_argument("--readings", type=int, default=sc.SphereSensor().readings)
    add_overrides(parser)
    args = parser.parse_args()
    methods = args.methods.split(",")
    radius = as_vehicle("drake_default").collision_radius
    worlds = []
    try:  # every world read and layered before anything flies
        layers = overrides(args)
        for index in args.worlds:
            path = os.path.join(args.worlds_dir, f"world_{index}.world")
            scenario = barn_scenario(path, f"barn_{index}")
            scenario.engine = args.engine
            scenario.sensor.readings = args.readings
            worlds.append((index, path, with_overrides(scenario, layers)))
    except (ScenarioError, OSError, ET.ParseError) as e:
        parser.error(str(e))
    os.makedirs(args.out, exist_ok=True)
    records = []
    for index, path, scenario in worlds:
        widest = widest_passage(cylinders(path))
        if args.write_scenarios:
            write_scenario(scenario, os.path.join(args.out, f"world_{index}.yaml"))
        for method in methods:
            m = simulate(scenario, method).metrics
            record = {
                "world": index,
                "method": method,
                "widest": round(widest, 3),
                "feasible": widest >= radius,
                "outcome": m["outcome"],
                "min_clearance": m["min_clearance"],
                "final_error": m["final_error"],
                "convergence_time": m["convergence_time"],
            }
            print(json.dumps(record), flush=True)
            records.append(record)
    text = "\n".join(json.dumps(r) for r in records) + "\n"
    write_text(os.path.join(args.out, "barn.jsonl"), text)
    write_text(os.path.join(args.out, "barn.md"), table(records, methods))
    print(table(records, methods))


if __name__ == "__main__":
    main()
