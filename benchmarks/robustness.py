"""How far MFI's success survives each imperfection of `mfi_drake.faults`.

    python benchmarks/robustness.py [--n 100] [--methods mfi] [--workers 2]
                                    [--only TEXT] [--out out/robustness]
                                    [--set YAML] [--override FILE]

For each imperfection and each of its levels (LEVELS, from none to past the
point where it breaks) this flies the Monte Carlo sweep (`sweep.run_sweep`,
the same random fields as `mfi-drake sweep` at the default density, seed 0)
with that `faults:` block on every field (after the --set / --override
layers, e.g. a `tune` winner), i.e. what `mfi-drake sweep [--override
FILE] --faults '{...}' --out DIR` does level by level. All
levels share DIR/results.jsonl, keyed by the fault variant, so an
interrupted run resumes where it stopped.

Writes DIR/robustness.md (the table: success and collision rates with 95 %
Wilson intervals, timeouts and errors per level, and the break points) and
DIR/robustness.json. Timeout: not within the goal tolerance at the end and
no collision; error: the simulation raised (a tumble into the plant's
roll-pitch-yaw gimbal lock).
The break point of an imperfection is its smallest level whose success
rate is significantly below the fault-free one: the two 95 % intervals do
not overlap.
"""

import argparse
import os
from functools import partial

from mfi_drake.app.arguments import add_overrides, overrides
from mfi_drake.config.faults import Faults
from mfi_drake.config.scenario import ScenarioError
from mfi_drake.files import write_json, write_text
from mfi_drake.studies.cluster import ClusterError, dask_client, require_dask
from mfi_drake.studies.stats import rate_cell
from mfi_drake.studies.sweep import SweepConfig, run_sweep
from mfi_drake.studies.variants import layered, variant_name

# imperfection -> (its unit, its levels as Faults), flown in this order (motor
# lag last: its failing flights tumble and take ~40 s each). Motor lag keeps RotorS'
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
        [(t, Faults(sensor_latency=t)) for t in (0.1, 0.2, 0.4, 0.8)],
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
    "motor time constant (up; down = 2×)": (
        "s",
        [
            (t, Faults(motor_time_constant=t, motor_time_constant_down=2 * t))
            for t in (0.0125, 0.05, 0.1)
        ],
    ),
}


def _row(name: str, level: str, stats: dict, broken: bool) -> str:
    n = stats["n"]
    cells = [rate_cell(stats, "success"), rate_cell(stats, "collision")]
    cells += [f"{round(stats[f'{o}_rate'] * n)}" for o in ("timeout", "error")]
    mark = " **breaks**" if broken else ""
    return f"| {name} | {level}{mark} | {n} | {' | '.join(cells)} |"


def break_point(clean: dict, levels: list[tuple[float, dict]]) -> float | None:
    """The smallest level whose success interval lies wholly below the
    fault-free one, None if there is none."""
    for level, stats in levels:
        if stats["success_rate_ci95"][1] < clean["success_rate_ci95"][0]:
            return level
    return None


def robustness_table(results: dict, methods: list[str]) -> str:
    """One Markdown table per method: a row per imperfection and level, the
    break point marked; then the break points in one line each."""
    lines = []
    for method in methods:
        clean = results["none"][method]
        lines += [
            f"**{method}**",
            "",
            "| imperfection [unit] | level | flights | success [95% CI] "
            "| collision [95% CI] | timeouts | errors |",
            "|---|---|---|---|---|---|---|",
            _row("none", "–", clean, False),
        ]
        verdicts = []
        for name, (unit, _) in LEVELS.items():
            if name not in results:  # not flown (--only)
                continue
            levels = [(level, stats[method]) for level, stats in results[name]]
            broken = break_point(clean, levels)
            for level, stats in levels:
                lines.append(
                    _row(f"{name} [{unit}]", f"{level:g}", stats, broken == level)
                )
            verdicts.append(
                f"- {name}: "
                + (
                    "no break within the levels flown"
                    if broken is None
                    else f"breaks at {broken:g}{'' if unit == '-' else ' ' + unit}"
                )
            )
        lines += ["", *verdicts, ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="fields per cell")
    parser.add_argument("--methods", default="mfi", help="comma-separated")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="out/robustness")
    parser.add_argument(
        "--only",
        help="fly only the imperfections whose name contains this text "
        "(e.g. 'state estimate'), besides the fault-free cell",
    )
    add_overrides(parser)
    args = parser.parse_args()
    methods = args.methods.split(",")
    try:
        layers = overrides(args)
        require_dask()
    except (ScenarioError, ClusterError) as e:
        parser.error(str(e))
    cells = [("none", None, None)] + [
        (name, level, faults)
        for name, (_, levels) in LEVELS.items()
        if args.only is None or args.only in name
        for level, faults in levels
    ]
    results: dict = {}
    with dask_client(args.workers, None) as client:
        for name, level, faults in cells:
            config = SweepConfig(
                n=args.n,
                methods=methods,
                out=args.out,
                variant=variant_name(layers, faults),
            )
            run = run_sweep(
                config, client, partial(layered, overrides=layers, faults=faults)
            )
            stats = {m: run.summary["methods"][m] for m in methods}
            if faults is None:
                results[name] = stats
            else:
                results.setdefault(name, []).append((level, stats))
            # Written after every cell, so a long run can be read as it goes.
            write_json(os.path.join(args.out, "robustness.json"), results)
            table = robustness_table(results, methods)
            write_text(os.path.join(args.out, "robustness.md"), table + "\n")
    print(table)


if __name__ == "__main__":
    main()
