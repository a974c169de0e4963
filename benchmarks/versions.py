"""Speed on both ends of the supported range, measured in one run: the
planar wall's real-time factor and the sweep's flights per minute under two
Python interpreters (each with this checkout and its own Drake installed),
flown in turn so that both see the same machine load.

    python benchmarks/versions.py PYTHON_A PYTHON_B [--rounds 2] [--repeats 5]
        [--fields 16] [--seed S] [--page docs/performance.md]

e.g. `python benchmarks/versions.py .venv/bin/python .venv313/bin/python`.
Each round runs, for A then B, a fresh child process that flies the planar
wall --repeats times (`throughput.mfi_run`, best wall time kept) and then an
MFI sweep of --fields fresh fields on a local cluster of 2 workers
(`throughput.flights_per_minute`, start-up included). Both ends fly the same
fields (the same seed). Each end keeps its best over the rounds; the ratios
B / A are printed. With --page the output is written into that page between
`<!-- BEGIN versions -->` and `<!-- END versions -->`.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from importlib.metadata import version

import throughput

HERE = os.path.abspath(__file__)


def one_end(repeats: int, fields: int, seed: int) -> dict:
    """What a child measures under its own interpreter."""
    scenario = throughput.load_scenario(throughput.PLANAR_WALL)
    wall = throughput.best([throughput.mfi_run(scenario) for _ in range(repeats)])
    _, rate = throughput.flights_per_minute(2, fields, seed)
    return {
        "python": sys.version.split()[0],
        "drake": version("drake"),
        "realtime_factor": wall.realtime_factor,
        "cpu_realtime_factor": wall.cpu_realtime_factor,
        "steps": wall.steps,
        "flights_per_minute": rate,
    }


def measure(python: str, repeats: int, fields: int, seed: int) -> dict:
    args = [python, HERE, "--one-end", str(repeats), str(fields), str(seed)]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("pythons", nargs="*", help="two interpreters: A then B")
    parser.add_argument("--rounds", type=int, default=2, help="A, B turns (>= 1)")
    parser.add_argument("--repeats", type=int, default=5, help="planar wall flights")
    parser.add_argument("--fields", type=int, default=16, help="fields per sweep")
    parser.add_argument("--seed", type=int, help="the sweeps' seed (default: time)")
    parser.add_argument("--page", help="a page to write the output into")
    parser.add_argument("--one-end", nargs=3, type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one_end:
        print(json.dumps(one_end(*args.one_end)))
        return {}
    if len(args.pythons) != 2:
        parser.error(f"pythons = {args.pythons}: give exactly two interpreters")
    for name in ("rounds", "repeats", "fields"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} = {getattr(args, name)}: must be >= 1")
    seed = args.seed if args.seed is not None else int(time.time()) % 1_000_000
    lines = [
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {args.rounds} "
        f"round(s), planar wall best of {args.repeats}, sweep of {args.fields} "
        f"fields (seed {seed}) on 2 workers"
    ]

    def say(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    print(lines[0])
    ends: dict[str, list[dict]] = {p: [] for p in args.pythons}
    for turn in range(args.rounds):
        for python in args.pythons:
            before = throughput.load()
            r = measure(python, args.repeats, args.fields, seed)
            ends[python].append(r)
            say(
                f"round {turn + 1}: Python {r['python']}, drake {r['drake']}: "
                f"planar wall {r['realtime_factor']:.1f}x real time "
                f"(CPU {r['cpu_realtime_factor']:.1f}x, "
                f"{r['steps']} steps), sweep {r['flights_per_minute']:.1f} "
                f"flights/min ({before} before)"
            )
    best = {
        p: {
            k: max(r[k] for r in runs)
            for k in ("realtime_factor", "cpu_realtime_factor", "flights_per_minute")
        }
        | {"python": runs[0]["python"], "drake": runs[0]["drake"]}
        for p, runs in ends.items()
    }
    a, b = (best[p] for p in args.pythons)
    for key, what in (
        ("realtime_factor", "real-time factor"),
        ("cpu_realtime_factor", "CPU real-time factor"),
        ("flights_per_minute", "flights/min"),
    ):
        say(
            f"best {what}: {a[key]:.1f} (Python {a['python']}, drake {a['drake']}) "
            f"and {b[key]:.1f} (Python {b['python']}, drake {b['drake']}): "
            f"B / A = {b[key] / a[key]:.3f}"
        )
    if args.page:
        throughput.write_section(
            args.page, "versions", "```\n" + "\n".join(lines) + "\n```"
        )
    return best


if __name__ == "__main__":
    main()
