"""The ablation of MFI's repairs on held-out fields.

    python benchmarks/ablation.py [--n 100] [--seed 2026] [--density 0.1 0.2]
                                  [--override FILE] [--workers 2]
                                  [--out out/ablation]

Flies the default MFI and, for each repair of `NavigatorParams` (a)–(h) and
the chain's `brake_first`, the default MFI with that one toggled (the ones
on turned off, the ones off turned on), with `brake_margin` 0.1 (or 0 if
that is the default), and the paper's literal MFI, on the same held-out fields
(`mfi-drake sweep`'s fields at --seed, which `mfi-drake tune` never trains
on), with the tuned gains of --override if given. All variants share
DIR/results.jsonl, keyed by their override, so an interrupted run resumes.

Writes DIR/ablation.md (success and collision rates with 95 % Wilson
intervals, the median path ratio with its interval, and the median number
of integrator steps, per variant and density) and DIR/ablation.json.
"""

import argparse
import json
import os
from functools import partial

import numpy as np

from mfi_drake.config.parameters import REPAIRS, NavigatorParams, paper_form
from mfi_drake.config.scenario_yaml import read_override
from mfi_drake.files import write_json, write_text
from mfi_drake.studies.cluster import dask_client
from mfi_drake.studies.records import read_results, record_key
from mfi_drake.studies.stats import rate_cell
from mfi_drake.studies.sweep import SweepConfig, run_sweep
from mfi_drake.studies.variants import override_variant, with_overrides


def variants() -> list[tuple[str, str]]:
    """(name, the navigator override YAML) of each variant flown."""
    default = NavigatorParams()
    out = [("default MFI", "")]
    # The repairs, then the vehicle chain's saturation rule (every method's).
    for repair in (*REPAIRS, "brake_first"):
        on = getattr(default, repair)
        out.append((f"{repair} {'off' if on else 'on'}", f"{{{repair}: {not on}}}"))
    margin = 0.1 if default.brake_margin == 0.0 else 0.0
    out.append((f"brake_margin {margin:g}", f"{{brake_margin: {margin:g}}}"))
    paper = paper_form(default)
    out.append(("paper's form (every repair off)", json.dumps(
        {r: getattr(paper, r) for r in REPAIRS}
    )))  # fmt: skip
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="fields per density")
    parser.add_argument("--seed", type=int, default=2026, help="held-out seed")
    parser.add_argument("--density", type=float, nargs="+", default=[0.1, 0.2])
    parser.add_argument("--override", help="tuned gains (mfi-drake tune)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default="out/ablation")
    args = parser.parse_args()
    base = [read_override(args.override)] if args.override else []
    rows = []
    with dask_client(args.workers, None) as client:
        for name, navigator in variants():
            layers = base + ([(name, f"navigator: {navigator}")] if navigator else [])
            config = SweepConfig(
                n=args.n,
                seed=args.seed,
                methods=["mfi"],
                densities=args.density,
                out=args.out,
                variant=override_variant(layers),
            )
            run = run_sweep(config, client, partial(with_overrides, overrides=layers))
            wanted = set(config.flight_keys())
            records = [
                r
                for r in read_results(os.path.join(args.out, "results.jsonl"))
                if record_key(r) in wanted
            ]
            for density, stats in run.summary["methods"]["mfi"]["by_density"].items():
                steps = [r["steps"] for r in records if f"{r['density']:g}" == density]
                rows.append((name, density, stats, float(np.median(steps))))
            write_json(os.path.join(args.out, "ablation.json"), rows)
            write_text(os.path.join(args.out, "ablation.md"), table(args, rows))
    print(table(args, rows))


def table(args, rows) -> str:
    lines = [
        "# Ablation of MFI's repairs (held-out fields)",
        "",
        f"Written by `python benchmarks/ablation.py`: seed {args.seed}, {args.n} "
        f"fields per density"
        + (f", gains of {args.override}" if args.override else "")
        + ".",
        "",
        "| variant | density | flights | success [95% CI] | collision [95% CI] "
        "| median path ratio [95% CI] | median steps |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, density, s, steps in rows:
        ci = s["median_path_ratio_ci95"]
        ratio = "–" if s["median_path_ratio"] is None else (
            f"{s['median_path_ratio']:.3f} [{ci[0]:.3f}, {ci[1]:.3f}]"
        )  # fmt: skip
        lines.append(
            f"| {name} | {density} | {s['n']} | {rate_cell(s, 'success')} "
            f"| {rate_cell(s, 'collision')} | {ratio} | {steps:.0f} |"
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
