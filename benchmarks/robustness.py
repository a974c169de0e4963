"""How far MFI's success survives each imperfection of `mfi_drake.faults`.

    python benchmarks/robustness.py [--n 100] [--methods mfi] [--workers 2]
                                    [--out out/robustness]

For each imperfection and each of its levels (LEVELS, from none to past the
point where it breaks) this flies the Monte Carlo sweep (`sweep.run_sweep`,
the same random fields as `mfi-drake sweep` at the default density, seed 0)
with that `faults:` block on every field, i.e. what
`mfi-drake sweep --faults '{...}' --out DIR` does level by level. All
levels share DIR/results.jsonl, keyed by the fault variant, so an
interrupted run resumes where it stopped.

Writes DIR/robustness.md (the table: success and collision rates with 95 %
Wilson intervals per level, and the break point) and DIR/robustness.json.
The break point of an imperfection is its smallest level whose success
rate is significantly below the fault-free one: the two 95 % intervals do
not overlap.
"""

import argparse
import os
from functools import partial

from mfi_drake.faults import Faults, fault_variant, with_faults
from mfi_drake.outputs import write_json, write_text
from mfi_drake.sweep import SweepConfig, dask_client, run_sweep

# imperfection -> (its unit, its levels as Faults). Motor lag keeps RotorS'
# Pelican ratio: spinning down takes twice as long as spinning up. The state
# estimate error puts the same number on position [m] and velocity [m/s].
LEVELS: dict[str, tuple[str, list[tuple[float, Faults]]]] = {
    "sensor noise std": (
        "m",
        [(s, Faults(sensor_noise_std=s)) for s in (0.1, 0.2, 0.4)],
    ),
    "dropout probability": (
        "-",
        [(p, Faults(dropout_prob=p)) for p in (0.3, 0.6, 0.9)],
    ),
    "sensor latency": (
        "s",
        [(t, Faults(sensor_latency=t)) for t in (0.2, 0.4, 0.8)],
    ),
    "motor time constant (up; down = 2×)": (
        "s",
        [
            (t, Faults(motor_time_constant=t, motor_time_constant_down=2 * t))
            for t in (0.0125, 0.05, 0.1)
        ],
    ),
    "weak rotor 0, fraction of thrust": (
        "-",
        [(f, Faults(weak_rotor_fraction=f)) for f in (0.97, 0.95, 0.9)],
    ),
    "state estimate error std (position, velocity)": (
        "m, m/s",
        [
            (s, Faults(position_noise_std=s, velocity_noise_std=s))
            for s in (0.05, 0.1, 0.2)
        ],
    ),
}


def _cell(stats: dict) -> str:
    """success [CI] / collision [CI], then how many timed out or raised (a
    tumble into the plant's gimbal lock)."""
    s, c = stats["success_rate"], stats["collision_rate"]
    s_ci, c_ci = stats["success_rate_ci95"], stats["collision_rate_ci95"]
    n = stats["n"]
    timeouts = round(stats["timeout_rate"] * n)
    errors = round(stats["error_rate"] * n)
    return (
        f"{s:.2f} [{s_ci[0]:.2f}, {s_ci[1]:.2f}] / "
        f"{c:.2f} [{c_ci[0]:.2f}, {c_ci[1]:.2f}] ({timeouts} T, {errors} E)"
    )


def break_point(clean: dict, levels: list[tuple[float, dict]]) -> float | None:
    """The smallest level whose success interval lies wholly below the
    fault-free one, None if there is none."""
    for level, stats in levels:
        if stats["success_rate_ci95"][1] < clean["success_rate_ci95"][0]:
            return level
    return None


def robustness_table(results: dict, methods: list[str], n: int) -> str:
    lines = [
        f"Success / collision rate [95 % Wilson interval], {n} random fields per "
        "cell (the sweep's default density, seed 0), then the number of "
        "timeouts (T: not at the goal at the end, no collision) and errors (E: "
        "the simulation raised, a tumble into gimbal lock).",
        "",
    ]
    for method in methods:
        clean = results["none"][method]
        lines += [
            f"**{method}** (no faults: {_cell(clean)})",
            "",
            "| imperfection [unit] | level 1 | level 2 | level 3 | breaks at |",
            "|---|---|---|---|---|",
        ]
        for name, (unit, all_levels) in LEVELS.items():
            levels = [(level, stats[method]) for level, stats in results.get(name, [])]
            broken = break_point(clean, levels)
            cells = [f"{level:g}: {_cell(stats)}" for level, stats in levels]
            cells += ["not flown yet"] * (len(all_levels) - len(levels))
            verdict = "not within these levels" if broken is None else f"{broken:g}"
            lines.append(f"| {name} [{unit}] | {' | '.join(cells)} | {verdict} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="fields per cell")
    parser.add_argument("--methods", default="mfi", help="comma-separated")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="out/robustness")
    args = parser.parse_args()
    methods = args.methods.split(",")
    cells = [("none", None, None)] + [
        (name, level, faults)
        for name, (_, levels) in LEVELS.items()
        for level, faults in levels
    ]
    results: dict = {}
    with dask_client(args.workers, None) as client:
        for name, level, faults in cells:
            config = SweepConfig(
                n=args.n,
                methods=methods,
                out=args.out,
                variant="" if faults is None else fault_variant(faults),
            )
            modify = None if faults is None else partial(with_faults, faults=faults)
            run = run_sweep(config, client, modify)
            stats = {m: run.summary["methods"][m] for m in methods}
            if faults is None:
                results[name] = stats
            else:
                results.setdefault(name, []).append((level, stats))
            # Written after every cell, so a long run can be read as it goes.
            write_json(os.path.join(args.out, "robustness.json"), results)
            table = robustness_table(results, methods, args.n)
            write_text(os.path.join(args.out, "robustness.md"), table + "\n")
    print(table)


if __name__ == "__main__":
    main()
