"""Flights per minute of `mfi-drake sweep` with 1 and 2 local Dask workers.

    python benchmarks/sweep_scaling.py [--fields 16] [--seed 1]

Runs the same sweep (MFI on --fields random fields at the default density,
each with its reference path) on a LocalCluster of one worker process and
then of two, and prints, measured in this one run: the wall time of each
sweep (cluster start-up and the workers' imports excluded: every worker
imports Drake and mfi_drake before the clock starts), flights per minute,
and the scaling efficiency rate(2) / (2 · rate(1)).

The machine has 2 cores shared with whatever else runs: the load average is
printed before each sweep, and a loaded machine shows up as an efficiency
well below 1 that says nothing about Dask.
"""

import argparse
import io
import os
import tempfile
import time

from mfi_drake.studies.sweep import SweepConfig, dask_client, run_sweep


def _import_in_worker() -> None:
    import mfi_drake.flight.simulation  # noqa: F401
    import mfi_drake.world.reference_path  # noqa: F401


def flights_per_minute(workers: int, fields: int, seed: int) -> tuple[float, float]:
    """(wall time [s], flights per minute) of one sweep on `workers` workers."""
    with tempfile.TemporaryDirectory() as out, dask_client(workers, None) as client:
        client.run(_import_in_worker)
        config = SweepConfig(n=fields, seed=seed, methods=["mfi"], out=out)
        start = time.perf_counter()
        run = run_sweep(config, client, progress_stream=io.StringIO())
        wall = time.perf_counter() - start
    if run.ran != fields or run.lost:
        raise RuntimeError(f"expected {fields} flights, ran {run.ran}: {run.lost}")
    return wall, 60.0 * fields / wall


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fields", type=int, default=16, help="flights per sweep")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    if args.fields < 1:
        parser.error(f"--fields = {args.fields}: must be ≥ 1")
    print(f"{args.fields} MFI flights (seed {args.seed}), cores: {os.cpu_count()}")
    rates = {}
    for workers in (1, 2):
        load = os.getloadavg()[0]
        wall, rates[workers] = flights_per_minute(workers, args.fields, args.seed)
        print(
            f"{workers} worker{'s' if workers > 1 else ''}: {wall:6.1f} s, "
            f"{rates[workers]:5.1f} flights/min (load average before: {load:.2f})"
        )
    efficiency = rates[2] / (2 * rates[1])
    print(f"scaling efficiency rate(2) / (2 rate(1)): {efficiency:.2f}")
    return {"rates": rates, "efficiency": efficiency}


if __name__ == "__main__":
    main()
