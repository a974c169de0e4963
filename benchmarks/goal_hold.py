"""A goal once held is still held: every shipped scene flown for 120 s by
the default `mfi` (issue 50's bar; docs/goals.md).

    python benchmarks/goal_hold.py [--scenarios scenarios] [--duration 120]
                                   [--workers 1] [--out docs/results/goal_hold]

Every scenario file under --scenarios that flies on its own (a file that
only overrides others', as sensors/rig3.yaml, is skipped), its duration set
to --duration and flown to the end (not stopped at rest), every vehicle of
a fleet counted. Per vehicle: the first time it is within the goal
tolerance (arrival), the largest error after arrival, the final error, and
whether the goal is held at the end (final error within the tolerance).
Writes OUT/goal_hold.md (the table), complete or absent.
"""

import argparse
import dataclasses
import glob
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from mfi_drake.config.scenario import ScenarioError
from mfi_drake.files import write_text
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.validation import load_scenario


def vehicle_rows(flight) -> list[dict]:
    """One row a vehicle of `flight` (the lead, then the others)."""
    rows = []
    for index, one in enumerate([flight, *flight.others]):
        scenario = one.scenario
        error = np.linalg.norm(one.positions - np.asarray(scenario.goal), axis=1)
        within = np.flatnonzero(error <= scenario.goal_tolerance)
        arrival = float(one.times[within[0]]) if len(within) else None
        rows.append(
            {
                "vehicle": index,
                "arrival": arrival,
                "after": float(error[within[0] :].max()) if len(within) else None,
                "final": float(error[-1]),
                "tolerance": scenario.goal_tolerance,
                "outcome": one.metrics["outcome"],
                "held": bool(error[-1] <= scenario.goal_tolerance),
            }
        )
    return rows


def fly(task: tuple[str, float]) -> tuple[str, list[dict]]:
    path, duration = task
    scenario = dataclasses.replace(load_scenario(path), duration=duration)
    return os.path.basename(path), vehicle_rows(simulate(scenario, "mfi"))


def scenario_files(folder: str) -> list[str]:
    """The scenario files of `folder` (recursively) that load on their own."""
    files = []
    for path in sorted(glob.glob(os.path.join(folder, "**", "*.yaml"), recursive=True)):
        try:
            load_scenario(path)
        except ScenarioError as e:
            print(f"skipped {path}: {e}")
            continue
        files.append(path)
    return files


def table(results: list[tuple[str, list[dict]]], duration: float) -> str:
    lines = [
        f"Every shipped scene flown for {duration:g} s by the default `mfi` "
        "(`python benchmarks/goal_hold.py`): per vehicle, the first time within "
        "the goal tolerance, the largest error after it, the error at the end.",
        "",
        "| scene | vehicle | outcome | arrival [s] | largest error after [m] "
        "| final error [m] | held at the end |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, rows in results:
        for row in rows:
            arrival = "never" if row["arrival"] is None else f"{row['arrival']:.1f}"
            after = "–" if row["after"] is None else f"{row['after']:.3f}"
            lines.append(
                f"| {name} | {row['vehicle']} | {row['outcome']} | {arrival} "
                f"| {after} | {row['final']:.3f} | {'yes' if row['held'] else 'no'} |"
            )
    rows = [row for _, rows in results for row in rows]
    arrived = [row for row in rows if row["arrival"] is not None]
    lines += [
        "",
        f"{len(arrived)} of {len(rows)} vehicles arrived; "
        f"{sum(row['held'] for row in arrived)} of those hold their goal at "
        f"the end.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenarios", default="scenarios")
    parser.add_argument("--duration", type=float, default=120.0)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="docs/results/goal_hold")
    args = parser.parse_args()
    tasks = [(path, args.duration) for path in scenario_files(args.scenarios)]
    with ProcessPoolExecutor(args.workers) as pool:
        results = []
        for name, rows in pool.map(fly, tasks):
            for row in rows:
                print(name, row, flush=True)
            results.append((name, rows))
    write_text(os.path.join(args.out, "goal_hold.md"), table(results, args.duration))


if __name__ == "__main__":
    main()
