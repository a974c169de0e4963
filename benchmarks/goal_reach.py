"""Reach against the goal's gap from a surface, every method, before and
after the terminal approach (docs/goals.md).

    python benchmarks/goal_reach.py [--gaps 0.25 0.3 0.4 0.5 0.6] [--workers 1]
        [--layouts wall_ahead ...] [--out docs/figures]

Flies every scene of `world.goal_scenes.LAYOUTS` (or --layouts) at every
gap with mfi, gf, apf (each with its terminal approach on, "after", and off,
"before":
`goal_scenes.without_terminal_approach`) and mfi-paper (the paper's field,
which has none), each ended at rest at the goal or at contact as a sweep
ends it. Writes OUT/goal_reach.png (per method: the successes out of the
layouts and the median final distance to the goal, against the gap) and
OUT/goal_reach.md (the table), each complete or absent.
"""

import argparse
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from mfi_drake.files import write_text
from mfi_drake.flight.methods import appearance
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.sweep import SWEEP_ENDS
from mfi_drake.world.goal_scenes import (
    LAYOUTS,
    goal_scene,
    without_terminal_approach,
)

METHODS = ("mfi", "gf", "apf", "mfi-paper")
WITH_APPROACH = ("mfi", "gf", "apf")  # mfi-paper has none: flown once


def fly(task: tuple) -> dict:
    layout, gap, method, approach = task
    scenario = goal_scene(layout, gap)
    if not approach:
        scenario = without_terminal_approach(scenario)
    m = simulate(scenario, method, **SWEEP_ENDS).metrics
    keep = ("outcome", "final_error", "min_clearance", "convergence_time", "steps")
    return {"layout": layout, "gap": gap, "method": method, "approach": approach} | {
        k: m[k] for k in keep
    }


def tasks(layouts, gaps) -> list[tuple]:
    return [
        (layout, gap, method, approach)
        for layout in layouts
        for gap in gaps
        for method in METHODS
        for approach in ((True, False) if method in WITH_APPROACH else (False,))
    ]


def curves(records: list[dict], gaps) -> dict:
    """(method, approach) → per gap: (successes, flights, collisions,
    median final distance to the goal)."""
    out = {}
    for method in METHODS:
        for approach in (True, False) if method in WITH_APPROACH else (False,):
            rows = []
            for gap in gaps:
                mine = [
                    r
                    for r in records
                    if (r["method"], r["approach"], r["gap"]) == (method, approach, gap)
                ]
                rows.append(
                    (
                        sum(r["outcome"] == "success" for r in mine),
                        len(mine),
                        sum(r["outcome"] == "collision" for r in mine),
                        float(np.median([r["final_error"] for r in mine])),
                    )
                )
            out[method, approach] = rows
    return out


def table(records: list[dict], gaps) -> str:
    layouts = list(dict.fromkeys(r["layout"] for r in records))
    lines = [
        "Successes of the layouts (" + ", ".join(layouts) + "), collisions and "
        "the median final distance to the goal [m], against the goal's gap "
        "from the surface [m]. Before: the terminal approach off.",
        "",
        "| method | " + " | ".join(f"{g:g} m" for g in gaps) + " |",
        "|---|" + "---|" * len(gaps),
    ]
    for (method, approach), rows in curves(records, gaps).items():
        name = (
            method
            if method not in WITH_APPROACH
            else f"{method}, " + ("after" if approach else "before")
        )
        cells = [
            f"{ok}/{n}" + (f", {hit} coll." if hit else "") + f", {err:.3f}"
            for ok, n, hit, err in rows
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "| layout | gap | method | before | after |", "|---|---|---|---|---|"]
    for r in records:
        if r["approach"] or r["method"] not in WITH_APPROACH:
            continue
        after = next(
            a
            for a in records
            if a["approach"]
            and (a["layout"], a["gap"], a["method"])
            == (r["layout"], r["gap"], r["method"])
        )
        lines.append(
            f"| {r['layout']} | {r['gap']:g} | {r['method']} "
            f"| {r['outcome']} ({r['final_error']:.3f} m) "
            f"| {after['outcome']} ({after['final_error']:.3f} m) |"
        )
    return "\n".join(lines) + "\n"


def figure(records: list[dict], gaps, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mfi_drake.app.figures import write_figure

    fig, (ax_ok, ax_err) = plt.subplots(1, 2, figsize=(10, 4))
    for (method, approach), rows in curves(records, gaps).items():
        label, colour = appearance(method)
        style = "-" if approach or method not in WITH_APPROACH else "--"
        when = (
            "" if method not in WITH_APPROACH else (" after" if approach else " before")
        )
        ok = [k / n for k, n, _, _ in rows]
        err = [e for *_, e in rows]
        ax_ok.plot(gaps, ok, style, marker="o", color=colour, label=label + when)
        ax_err.plot(gaps, err, style, marker="o", color=colour, label=label + when)
    ax_ok.set(
        xlabel="goal's gap from the surface [m]",
        ylabel="success (share of the layouts)",
        ylim=(-0.05, 1.05),
    )
    ax_err.set(
        xlabel="goal's gap from the surface [m]",
        ylabel="median final distance to the goal [m]",
    )
    ax_ok.legend(fontsize=7)
    for ax in (ax_ok, ax_err):
        ax.grid(alpha=0.3)
    fig.suptitle("Reaching a goal near a surface: dashed before, solid after")
    fig.tight_layout()
    write_figure(fig, path)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--gaps", type=float, nargs="+", default=[0.25, 0.3, 0.4, 0.5, 0.6]
    )
    parser.add_argument("--layouts", nargs="+", choices=LAYOUTS, default=LAYOUTS)
    parser.add_argument(
        "--workers", type=int, default=1, help="processes (1: this one)"
    )
    parser.add_argument("--out", default=os.path.join("docs", "figures"))
    args = parser.parse_args(argv)
    todo = tasks(args.layouts, args.gaps)
    if args.workers == 1:  # in this process
        records = [fly(task) for task in todo]
    else:
        with ProcessPoolExecutor(args.workers) as pool:
            records = list(pool.map(fly, todo))
    write_text(os.path.join(args.out, "goal_reach.md"), table(records, args.gaps))
    figure(records, args.gaps, os.path.join(args.out, "goal_reach.png"))
    print(table(records, args.gaps).split("\n\n")[1])
    return records


if __name__ == "__main__":
    main()
