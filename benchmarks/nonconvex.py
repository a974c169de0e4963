"""Every method on the non-convex worlds (docs/nonconvex.md).

    python benchmarks/nonconvex.py [--seed 0] [--count 3] [--world nonconvex]
        [--methods mfi,mfi-memoryless,...] [--workers 1] [--out out/nonconvex_s0]

Flies worlds 0..count−1 of seed `seed` of every class of
`world.nonconvex.KINDS` (or of the one class --world names) with every
method: `mfi-drake sweep --world` (`studies.sweep.run_sweep`, its records
in OUT/results.jsonl, resumed), and prints the held-out table of
docs/nonconvex.md: per class and method, success / collision / timeout
(and trapped).

    python benchmarks/nonconvex.py --cost 3

The memory's cost: random fields 0..2 of seed 0 at density 0.1 (convex,
where the escape rule never traps, so its flights are the memoryless MFI's
step for step but where the corner brake acts), each flown by
"mfi-memoryless" and "mfi"; prints the CPU µs per integrator step of each
and whether the two logs are equal.
"""

import argparse

from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.flight.result import OUTCOMES
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.cluster import dask_client
from mfi_drake.studies.sweep import (
    NONCONVEX,
    SWEEP_ENDS,
    WORLDS,
    SweepConfig,
    run_sweep,
)
from mfi_drake.world.generator import random_field


def table(summary: dict) -> str:
    """Per class (rows) and method (columns): success/collision/timeout
    counts, and the trapped ones where there are."""
    methods = summary["methods"]
    kinds = list(next(iter(methods.values()))["by_world"])
    rows = ["| class | " + " | ".join(methods) + " |"]
    rows.append("|---" * (len(methods) + 1) + "|")
    for kind in [*kinds, "all"]:
        cells = []
        for stats in methods.values():
            s = stats if kind == "all" else stats["by_world"][kind]
            counts = [round(s[f"{o}_rate"] * s["n"]) if s["n"] else 0 for o in OUTCOMES]
            cell = "/".join(str(c) for c in counts[:3])
            cells.append(cell + (f" (+{counts[3]} trapped)" if counts[3] else ""))
        rows.append(f"| {kind} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def memory_cost(count: int) -> None:
    """See the module docstring (--cost)."""
    print("| field | mfi-memoryless µs/step | mfi µs/step | steps | same flight |")
    print("|---|---|---|---|---|")
    for index in range(count):
        world = random_field(0, index, 0.1)
        a, b = (simulate(world, m, **SWEEP_ENDS) for m in ("mfi-memoryless", "mfi"))
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
    parser.add_argument("--count", type=int, default=3)
    parser.add_argument("--world", default=NONCONVEX, choices=WORLDS[1:])
    parser.add_argument(
        "--methods", default=",".join([*DEFAULT_METHODS, "mfi-memoryless"])
    )
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="out/nonconvex_s0")
    parser.add_argument("--cost", type=int, default=0, help="see the docstring")
    args = parser.parse_args()
    if args.cost:
        memory_cost(args.cost)
        return
    config = SweepConfig(
        n=args.count,
        seed=args.seed,
        methods=args.methods.split(","),
        out=args.out,
        world=args.world,
    )
    with dask_client(args.workers, None, config.methods) as client:
        run = run_sweep(config, client)
    print(f"success/collision/timeout of {args.count} worlds a class, seed {args.seed}")
    print(table(run.summary))


if __name__ == "__main__":
    main()
