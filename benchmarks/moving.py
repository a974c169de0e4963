"""Every method among moving obstacles, on held-out fields (docs/dynamic.md).

    python benchmarks/moving.py [--n 30] [--seed 2026] [--density 0.1]
                                [--share 0.3] [--speeds 0.5 1.0 0.25]
                                [--ablation-speed 1.0] [--ablation-methods mfi]
                                [--workers 1] [--out docs/results/moving]
                                [--page docs/dynamic.md]

The fields of `mfi-drake sweep --seed S` with a share of their obstacles
circling at each speed (`mfi-drake sweep --moving SHARE --obstacle-speed
V`), flown by every method of the registry with the scenario defaults
(relative velocity, own pace); then, at --ablation-speed, the two other
ways a navigator can see moving obstacles, flown by --ablation-methods: the
relative fields as they are (own_pace off), and the vehicle's own velocity
(the estimate off); then the same fields with nothing moving, every method.
Every run shares DIR/results.jsonl, keyed by its variant, so an
interrupted run resumes.

Writes DIR/moving.md (success, collision and timeout rates with 95 % Wilson
intervals, the median path ratio and the median final error of the
timeouts, per speed, way and method) and DIR/moving.json, after each run,
and the summary (success and collisions per speed and method) into the
section "moving" of --page.
"""

import argparse
import os
from functools import partial

import numpy as np

from mfi_drake.files import write_json, write_section, write_text
from mfi_drake.flight.methods import DEFAULT_METHODS
from mfi_drake.studies.cluster import dask_client
from mfi_drake.studies.records import read_results, record_key
from mfi_drake.studies.stats import rate_cell
from mfi_drake.studies.sweep import SweepConfig, run_sweep
from mfi_drake.studies.variants import motion_variant, override_variant, with_overrides

WAYS = {
    "relative, own pace": "",  # the default
    "relative, full": "relative_velocity: {own_pace: false}",
    "own velocity": "relative_velocity: {enabled: false}",
}


def runs(args) -> list[tuple[float, str, list[str]]]:
    """(speed, way, methods) of each run, in the order flown (speed 0:
    static)."""
    every = list(DEFAULT_METHODS)
    ablation = args.ablation_methods.split(",")
    out = [(speed, "relative, own pace", every) for speed in args.speeds]
    out += [(args.ablation_speed, way, ablation) for way in list(WAYS)[1:]]
    return out + [(0.0, "relative, own pace", every)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=30, help="fields per cell")
    parser.add_argument("--seed", type=int, default=2026, help="held-out seed")
    parser.add_argument("--density", type=float, default=0.1)
    parser.add_argument("--share", type=float, default=0.3, help="moving share")
    parser.add_argument("--speeds", type=float, nargs="+", default=[0.5, 1.0, 0.25])
    parser.add_argument("--ablation-speed", type=float, default=1.0)
    parser.add_argument("--ablation-methods", default="mfi")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="docs/results/moving")
    parser.add_argument("--page", default="docs/dynamic.md")
    args = parser.parse_args()
    rows = []
    with dask_client(args.workers, None) as client:
        for speed, way, methods in runs(args):
            layers = [(way, WAYS[way])] if WAYS[way] else []
            share = args.share if speed > 0 else 0.0
            variants = [motion_variant(share, speed), override_variant(layers)]
            config = SweepConfig(
                n=args.n,
                seed=args.seed,
                methods=methods,
                densities=[args.density],
                out=args.out,
                variant=",".join(v for v in variants if v),
                moving=share,
                obstacle_speed=speed,
            )
            run = run_sweep(config, client, partial(with_overrides, overrides=layers))
            wanted = set(config.flight_keys())
            records = [
                r
                for r in read_results(os.path.join(args.out, "results.jsonl"))
                if record_key(r) in wanted
            ]
            for method, stats in run.summary["methods"].items():
                mine = [r for r in records if r["method"] == method]
                rows.append((speed, way, method, stats, _timeout_error(mine)))
            write_json(os.path.join(args.out, "moving.json"), rows)
            write_text(os.path.join(args.out, "moving.md"), table(args, rows))
            write_section(args.page, "moving", summary(args, rows))
    print(table(args, rows))


def _timeout_error(records: list[dict]) -> float | None:
    """The median final error of the flights that timed out [m]."""
    errors = [r["final_error"] for r in records if r["outcome"] == "timeout"]
    return float(np.median(errors)) if errors else None


def table(args, rows) -> str:
    lines = [
        "# Every method among moving obstacles (held-out fields)",
        "",
        f"Written by `python benchmarks/moving.py`: seed {args.seed}, {args.n} "
        f"fields at density {args.density:g}, a share {args.share:g} of the "
        "obstacles circling at the speed (0: the same fields, static).",
        "",
        "| speed [m/s] | how the navigator sees motion | method | flights "
        "| success [95% CI] | collision [95% CI] | timeout [95% CI] "
        "| median path ratio [95% CI] | timeouts' median final error [m] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for speed, way, method, s, error in rows:
        ci = s["median_path_ratio_ci95"]
        ratio = "–" if s["median_path_ratio"] is None else (
            f"{s['median_path_ratio']:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]"
        )  # fmt: skip
        lines.append(
            f"| {speed:g} | {_way(speed, way)} | {method} "
            f"| {s['n']} | {rate_cell(s, 'success')} "
            f"| {rate_cell(s, 'collision')} | {rate_cell(s, 'timeout')} | {ratio} "
            f"| {'–' if error is None else f'{error:.2f}'} |"
        )
    return "\n".join(lines) + "\n"


def summary(args, rows) -> str:
    """Success and collisions per speed and way (rows) and method (columns)."""
    methods = list(dict.fromkeys(method for _, _, method, _, _ in rows))
    cells: dict[tuple, dict[str, str]] = {}
    for speed, way, method, s, _ in rows:
        n = s["n"]
        hits = round(s["collision_rate"] * n)
        cells.setdefault((speed, way), {})[method] = (
            f"{s['success_rate']:.2f} ({hits} of {n} collided)"
        )
    lines = [
        f"Seed {args.seed}, {args.n} fields at density {args.density:g}, "
        f"{args.share:g} of the obstacles circling; success (collisions):",
        "",
        "| speed [m/s] | how the navigator sees motion | " + " | ".join(methods) + " |",
        "|---|---|" + "---|" * len(methods),
    ]
    for (speed, way), by_method in cells.items():
        row = [by_method.get(m, "–") for m in methods]
        lines.append(f"| {speed:g} | {_way(speed, way)} | " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def _way(speed: float, way: str) -> str:
    """How the navigator sees motion, as a row names it (speed 0: static)."""
    return way if speed else "(nothing moves)"


if __name__ == "__main__":
    main()
