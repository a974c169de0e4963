"""The two engines on the same random fields (docs/performance.md, "The two
engines fly the same flights").

    python benchmarks/engines.py [--n 30] [--seed 5] [--methods mfi,...]
        [--workers 1] [--out out/engines_s5]

Flies fields 0..n−1 of seed `seed` at density 0.1 with every method, once
with `engine: systems` (the card's diagram of LeafSystems) and once with
`engine: compiled` (the same chain in one compiled system), through the
sweep (`studies.sweep.run_sweep`, records in OUT/results.jsonl keyed by
the variant `engine: …`, resumed). Prints, per method, the fields whose
outcome differs (each named) and the largest differences of the metrics
over the rest: path length, least clearance, convergence time, steps.
"""

import argparse
import dataclasses

from mfi_drake.config.scenario import Scenario
from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.studies.cluster import dask_client
from mfi_drake.studies.records import read_results
from mfi_drake.studies.sweep import SweepConfig, run_sweep

ENGINES = ("systems", "compiled")
METRICS = ("path_length", "min_clearance", "convergence_time")


def on_engine(engine: str):
    def modify(scenario: Scenario) -> Scenario:
        return dataclasses.replace(scenario, engine=engine)

    return modify


def differences(records: list[dict], methods: list[str]) -> str:
    """The table of the module docstring, from the sweep's records."""
    flights = {(r["variant"], r["method"], r["scenario"]): r for r in records}
    rows = [
        "| method | fields | same outcome | outcome differs | "
        + " | ".join(f"max Δ {m}" for m in METRICS)
        + " | max Δ steps |",
        "|---" * (5 + len(METRICS)) + "|",
    ]
    for method in methods:
        pairs = [
            (r, flights.get((f"engine: {ENGINES[1]}", method, scenario)))
            for (variant, m, scenario), r in flights.items()
            if variant == f"engine: {ENGINES[0]}" and m == method
        ]
        pairs = [(a, b) for a, b in pairs if b is not None]
        turned = [a["scenario"] for a, b in pairs if a["outcome"] != b["outcome"]]
        same = [(a, b) for a, b in pairs if a["outcome"] == b["outcome"]]
        gaps = [
            max(
                (abs(a[m] - b[m]) for a, b in same if a[m] is not None),
                default=0.0,
            )
            for m in METRICS
        ]
        steps = max((abs(a["steps"] - b["steps"]) for a, b in same), default=0)
        rows.append(
            f"| {method} | {len(pairs)} | {len(same)} | {', '.join(turned) or '–'} | "
            + " | ".join(f"{g:.2g}" for g in gaps)
            + f" | {steps} |"
        )
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=30)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default=None, help="default: out/engines_s<seed>")
    args = parser.parse_args()
    methods = args.methods.split(",")
    out = args.out or f"out/engines_s{args.seed}"
    with dask_client(args.workers, None, methods) as client:
        for engine in ENGINES:
            config = SweepConfig(
                n=args.n,
                seed=args.seed,
                methods=methods,
                out=out,
                variant=f"engine: {engine}",
            )
            run_sweep(config, client, on_engine(engine))
    print(f"{args.n} random fields of seed {args.seed} at density 0.1, both engines")
    print(differences(read_results(f"{out}/results.jsonl"), methods))


if __name__ == "__main__":
    main()
