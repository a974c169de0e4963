"""How a fleet's cost grows with its size, and how its outcomes depend on
the exchange rate (docs/fleets.md).

    python benchmarks/fleet_scaling.py [--sizes 1,2,4,8,16,32]
                                       [--processes P] [--rates 5,10,20,50]
                                       [--figure PATH] [--page docs/dynamic.md]

Scaling: for each N, an antipodal circle of N vehicles (`world.fleets`,
radius `circle_radius(N)`, duration 5 s per metre of diameter) is flown by
MFI with the default exchange rate over P processes (default: one per
core), and one vehicle flies the same diameter alone (the reference, in the
same run). Printed: vehicle-seconds per second of CPU time (every
process's) and of wall time, and the fleet's over the reference's: the CPU
ratio is the work a vehicle-second costs, the wall ratio what the machine
delivers (on a shared machine the CPU ratio is the steadier).

Then, for the other design (one diagram and one error-controlled integrator
for the whole fleet): the steps such an integrator would take, estimated
from the flights just flown (`shared_steps`), and the CPU it could spend a
vehicle and step and still deliver 0.75 of the reference's rate.

Rates: the shipped swarms and three random fields of four vehicles (the
multi-vehicle sweep's, seed 0) flown at each exchange rate; printed:
outcome, least separation, and each vehicle's path length, with the
largest difference from the fastest rate's. (A perfectly symmetric circle
is left out: which way its vehicles break the symmetry is decided by
rounding, at any rate.) Then each scene at its own rate with its rule of
the road and without it (keep_right 0).
"""

import argparse
import os
from dataclasses import replace

import numpy as np

from mfi_drake.files import write_section
from mfi_drake.flight.simulation import simulate
from mfi_drake.world import generator
from mfi_drake.world.fleets import (
    antipodal_circle,
    random_pairs,
    with_vehicles,
)
from mfi_drake.world.validation import load_scenario

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def speeds(flight) -> tuple[float, float]:
    """Vehicle-seconds per CPU second and per wall second."""
    vehicle_seconds = (1 + len(flight.others)) * flight.metrics["sim_time"]
    return vehicle_seconds / flight.cpu_time, vehicle_seconds / flight.wall_time


# The window [s] within which `shared_steps` counts each vehicle's steps.
WINDOW = 0.05


def shared_steps(flights: list, duration: float) -> int:
    """The steps one error-controlled integrator of the whole fleet would
    take, estimated from its vehicles' separately integrated flights:
    Drake's error norm is the largest over the state's entries, so such a
    step is as short as the shortest of the vehicles' steps at that time.
    Per WINDOW, the most steps any vehicle took there; summed."""
    edges = np.arange(0.0, duration + WINDOW, WINDOW)
    most = np.zeros(len(edges) - 1)
    for flight in flights:
        most = np.maximum(most, np.histogram(np.unique(flight.times)[1:], edges)[0])
    return int(most.sum())


def alone(fleet):
    """The reference: the fleet's own vehicle flying its diameter alone."""
    return with_vehicles(replace(fleet, name="alone"), [(fleet.start, fleet.goal)])


def say(lines: list[str], line: str) -> None:
    """Prints a line of a table and keeps it for --page."""
    print(line, flush=True)
    lines.append(line)


def scaling(sizes: list[int], processes: int, lines: list[str]) -> list[dict]:
    say(
        lines,
        "| N | outcome | least separation [m] | vehicle-s per CPU s | per wall s "
        "| alone: per CPU s | per wall s | ratio (CPU) | ratio (wall) |",
    )
    say(lines, "|---|---|---|---|---|---|---|---|---|")
    rows = []
    for n in sizes:
        fleet = antipodal_circle(n)
        reference = simulate(alone(fleet))
        flown = simulate(fleet, processes=processes)
        cpu, wall = speeds(flown)
        cpu_ref, wall_ref = speeds(reference)
        separation = flown.metrics.get("min_separation")
        row = {
            "n": n,
            "outcome": flown.metrics["outcome"],
            "cpu": cpu,
            "wall": wall,
            "cpu_ref": cpu_ref,
            "ratio": cpu / cpu_ref,
            "ratio_wall": wall / wall_ref,
            "separation": separation,
        }
        vehicles = [flown, *flown.others]
        row["steps"] = np.mean([f.metrics["steps"] for f in vehicles])
        row["steps_ref"] = reference.metrics["steps"]
        row["shared"] = shared_steps(vehicles, flown.metrics["sim_time"])
        # µs of CPU a lone step costs, and what one step of one vehicle
        # may cost in a shared integrator for 0.75 of the lone rate.
        row["step_ref"] = 1e6 * reference.cpu_time / row["steps_ref"]
        row["budget"] = row["step_ref"] * row["steps_ref"] / row["shared"] / 0.75
        rows.append(row)
        sep = "–" if separation is None else f"{separation:.3f}"
        say(
            lines,
            f"| {n} | {row['outcome']} | {sep} | {cpu:.1f} | {wall:.1f} "
            f"| {cpu_ref:.1f} | {wall_ref:.1f} | {row['ratio']:.2f} "
            f"| {row['ratio_wall']:.2f} |",
        )
    return rows


def one_integrator(rows: list[dict], lines: list[str]) -> None:
    """The table of what one integrator for the whole fleet would allow."""
    say(
        lines,
        "| N | steps: alone | a fleet vehicle (mean) | one integrator (est.) "
        "| µs of CPU a lone step | allowed a vehicle and shared step "
        "| of a lone step |",
    )
    say(lines, "|---|---|---|---|---|---|---|")
    for r in rows:
        say(
            lines,
            f"| {r['n']} | {r['steps_ref']} | {r['steps']:.0f} | {r['shared']} "
            f"| {r['step_ref']:.0f} | {r['budget']:.0f} "
            f"| {r['budget'] / r['step_ref']:.2f} |",
        )


def rates(hz: list[float], lines: list[str], rule_lines: list[str]) -> None:
    """The rates table into `lines`; into `rule_lines`, each scene at its own
    rate with the rule of the road and without it (keep_right 0)."""
    scenes = [
        load_scenario(os.path.join(ROOT, "scenarios", f"{name}.yaml"))
        for name in ("swarm_circle", "swarm_corridor")
    ]
    scenes += [
        random_pairs(generator.random_field(0, i, 0.1), 4, 0, i) for i in range(3)
    ]
    say(
        lines,
        "| scene | rate [Hz] | outcome | least separation [m] "
        "| path lengths [m] | largest path difference from the fastest [m] |",
    )
    say(lines, "|---|---|---|---|---|---|")
    rule_rows = [
        "| scene | keep_right [°] | outcome | least separation [m] "
        "| path lengths [m] |",
        "|---|---|---|---|---|",
    ]
    for scene in scenes:
        flown = {r: simulate(replace(scene, exchange_hz=r)).metrics for r in hz}
        paths = {
            r: np.array([v["path_length"] for v in m["vehicles"]])
            for r, m in flown.items()
        }
        for r, m in flown.items():
            diff = np.abs(paths[r] - paths[max(hz)]).max()
            say(
                lines,
                f"| {scene.name} | {r:g} | {m['outcome']} "
                f"| {m['min_separation']:.3f} | {listed(paths[r])} | {diff:.3f} |",
            )
        estimate = scene.relative_velocity
        for turn in (estimate.keep_right, 0.0):
            if turn == estimate.keep_right and scene.exchange_hz in flown:
                m = flown[scene.exchange_hz]  # flown already, for the rates
            else:
                turned = replace(estimate, keep_right=turn)
                m = simulate(replace(scene, relative_velocity=turned)).metrics
            rule_rows.append(
                f"| {scene.name} | {turn:g} | {m['outcome']} "
                f"| {m['min_separation']:.3f} "
                f"| {listed([v['path_length'] for v in m['vehicles']])} |"
            )
    print(flush=True)
    for row in rule_rows:
        say(rule_lines, row)


def listed(paths: list[float]) -> str:
    return ", ".join(f"{p:.2f}" for p in paths)


def figure(rows: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mfi_drake.files import atomic_path

    n = [r["n"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(n, [r["cpu"] for r in rows], "o-", label="fleet, per CPU s")
    ax.plot(n, [r["wall"] for r in rows], "^-", label="fleet, per wall s")
    ax.plot(n, [r["cpu_ref"] for r in rows], "s--", label="one vehicle alone")
    ax.plot(n, [0.75 * r["cpu_ref"] for r in rows], ":", label="0.75 × alone")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("vehicles N (antipodal circle)")
    ax.set_ylabel("vehicle-seconds per second")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,2,4,8,16,32")
    parser.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--rates", default="5,10,20,50")
    parser.add_argument("--figure", default="")
    parser.add_argument(
        "--page",
        help="a page to write the tables into (sections fleet_scaling, "
        "fleet_rates, fleet_rule)",
    )
    args = parser.parse_args(argv)
    sizes = [int(n) for n in args.sizes.split(",") if n]
    if sizes:
        load = os.getloadavg()[0]  # the wall rates need an idle machine
        lines = [
            f"{args.processes} processes, {os.cpu_count()} cores, "
            f"load average {load:.1f} at the start:",
            "",
        ]
        rows = scaling(sizes, args.processes, lines)
        say(lines, "")
        one_integrator(rows, lines)
        if args.figure:
            figure(rows, args.figure)
        if args.page:
            write_section(args.page, "fleet_scaling", "\n".join(lines))
    if args.rates:
        lines, rule_lines = [], []
        rates([float(r) for r in args.rates.split(",")], lines, rule_lines)
        if args.page:
            write_section(args.page, "fleet_rates", "\n".join(lines))
            write_section(args.page, "fleet_rule", "\n".join(rule_lines))


if __name__ == "__main__":
    main()
