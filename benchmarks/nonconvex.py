"""Every method on the non-convex worlds (docs/nonconvex.md).

    python benchmarks/nonconvex.py [--seed 0] [--count 10] [--kinds cup ...]
        [--methods mfi mfi-nc ...] [--out out/nonconvex_s0.jsonl]

Flies worlds 0..count−1 of seed `seed` of every class of
`world.nonconvex.KINDS` (or --kinds) with every method, one process, each
ended at rest at the goal or at contact as a sweep ends it, and appends one
JSON line per flight to OUT (a flight already there is not flown again).
Prints the table: per class and method, success / collision / timeout (and
trapped), and the CPU seconds per integrator step.

    python benchmarks/nonconvex.py --cost 3

The memory's cost: random fields 0..2 of seed 0 at density 0.1 (convex,
where mfi-nc never traps, so its flights are MFI's step for step), each
flown by "mfi" and "mfi-nc"; prints the CPU µs per integrator step of each
and whether the two logs are equal.
"""

import argparse
import json
import os

from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.sweep import SWEEP_ENDS
from mfi_drake.world.generator import random_field
from mfi_drake.world.nonconvex import KINDS, nonconvex_world

OUTCOMES = ("success", "collision", "timeout", "trapped")


def fly(kind: str, seed: int, index: int, method: str) -> dict:
    flight = simulate(nonconvex_world(kind, seed, index), method, **SWEEP_ENDS)
    m = flight.metrics
    keep = ("outcome", "final_error", "min_clearance", "convergence_time")
    return (
        {"kind": kind, "seed": seed, "index": index, "method": method}
        | {k: m.get(k) for k in keep}
        | {
            "cpu_time": flight.cpu_time,
            "steps": flight.integrator_steps,
            "sim_time": float(flight.times[-1]),
        }
    )


def table(records: list[dict], methods, kinds) -> str:
    rows = ["| class | " + " | ".join(methods) + " |"]
    rows.append("|---" * (len(methods) + 1) + "|")
    for kind in [*kinds, "all"]:
        cells = []
        for method in methods:
            mine = [
                r
                for r in records
                if r["method"] == method and kind in (r["kind"], "all")
            ]
            counts = [sum(r["outcome"] == o for r in mine) for o in OUTCOMES]
            cell = "/".join(str(c) for c in counts[:3])
            cells.append(cell + (f" (+{counts[3]} trapped)" if counts[3] else ""))
        rows.append(f"| {kind} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def memory_cost(count: int) -> None:
    """See the module docstring (--cost)."""
    print("| field | mfi µs/step | mfi-nc µs/step | steps | same flight |")
    print("|---|---|---|---|---|")
    for index in range(count):
        world = random_field(0, index, 0.1)
        a, b = (simulate(world, m, **SWEEP_ENDS) for m in ("mfi", "mfi-nc"))
        same = (
            a.times.shape == b.times.shape and (a.log["state"] == b.log["state"]).all()
        )
        cost = [1e6 * f.cpu_time / f.integrator_steps for f in (a, b)]
        print(
            f"| {world.name} | {cost[0]:.0f} | {cost[1]:.0f} | "
            f"{a.integrator_steps} | {'yes' if same else 'no'} |",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--count", type=int, default=10)
    parser.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    parser.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    parser.add_argument("--out", default="out/nonconvex_s0.jsonl")
    parser.add_argument("--cost", type=int, default=0, help="see the docstring")
    args = parser.parse_args()
    if args.cost:
        memory_cost(args.cost)
        return
    records = []
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    if os.path.exists(args.out):
        with open(args.out) as f:
            records = [json.loads(line) for line in f if line.strip()]
    done = {(r["kind"], r["seed"], r["index"], r["method"]) for r in records}
    with open(args.out, "a") as f:
        for kind in args.kinds:
            for index in range(args.count):
                for method in args.methods:
                    key = (kind, args.seed, index, method)
                    if key in done:
                        continue
                    record = fly(*key)
                    print(json.dumps(record), flush=True)
                    f.write(json.dumps(record) + "\n")
                    f.flush()
                    records.append(record)
    mine = [r for r in records if r["seed"] == args.seed and r["index"] < args.count]
    print("success/collision/timeout of", args.count, "worlds a class, seed", args.seed)
    print(table(mine, args.methods, args.kinds))


if __name__ == "__main__":
    main()
