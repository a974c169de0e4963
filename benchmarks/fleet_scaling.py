"""How a fleet's cost grows with its size, and how its outcomes depend on
the exchange rate (docs/fleets.md).

    python benchmarks/fleet_scaling.py [--sizes 1,2,4,8,16,32]
                                       [--processes P] [--rates 5,10,20,50]
                                       [--compiled 1,8,16,32] [--field-seed S]
                                       [--field-seconds T]
                                       [--figure PATH] [--page docs/dynamic.md]

Scaling: for each N, an antipodal circle of N vehicles (`world.fleets`,
radius `circle_radius(N)`, duration 5 s per metre of diameter) is flown by
MFI by both designs (docs/fleets.md): separate integration with the
default exchange rate over P processes (default: one per core), and one
integrator (one process); and one vehicle flies the same diameter alone
(the reference, in the same run: the median of three flights). Printed:
vehicle-seconds per second of CPU time (every process's) and of wall time,
and the fleet's over the reference's: the CPU ratio is the work a
vehicle-second costs, the wall ratio what the machine delivers (on a
shared machine the CPU ratio is the steadier). The one integrator's build
time (its chain compiled, outside the flight) is printed apart.

Compiled: for each N of --compiled, the fleet on one integrator against
one vehicle alone on the compiled engine (`engine: compiled`, the same
compiled chain and sphere sensor with N = 1; the median of three), in empty
space (the antipodal circle, as above) and among static obstacles (field 0
of seed --field-seed at density 0.1, `random_pairs`; the lone vehicle is
the fleet's first, alone in the same field; each flown --field-seconds).
Printed: steps, vehicle-seconds per CPU second and the ratio to the lone
vehicle's, the flight's realtime factor (simulated over wall seconds) and
the whole call's (`simulate`: diagram, flight and metrics) beside it.

Rates: the shipped swarms and three random fields of four vehicles (the
multi-vehicle sweep's, seed 0) flown at each exchange rate, and on one
integrator (no exchange); printed: outcome, least separation, and each
vehicle's path length, with the largest difference from the fastest
rate's. (A perfectly symmetric circle
is left out: which way its vehicles break the symmetry is decided by
rounding, at any rate.) Then each scene at its own rate with its rule of
the road and without it (keep_right 0).
"""

import argparse
import os
import time
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


def alone(fleet):
    """The reference: the fleet's own vehicle flying its diameter alone."""
    return with_vehicles(replace(fleet, name="alone"), [(fleet.start, fleet.goal)])


def say(lines: list[str], line: str) -> None:
    """Prints a line of a table and keeps it for --page."""
    print(line, flush=True)
    lines.append(line)


DESIGNS = ("separate", "one")


def scaling(sizes: list[int], processes: int, lines: list[str]) -> list[dict]:
    say(
        lines,
        "| N | design | outcome | least separation [m] | steps | vehicle-s per CPU s "
        "| per wall s | alone: per CPU s | per wall s | ratio (CPU) | ratio (wall) "
        "| build [s] |",
    )
    say(lines, "|---|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for n in sizes:
        fleet = antipodal_circle(n)
        # The median of three: a lone flight is short, and its rate moved by
        # tens of per cent from one flight to the next on a shared machine.
        references = [speeds(simulate(alone(fleet))) for _ in range(3)]
        cpu_ref, wall_ref = np.median(references, axis=0)
        for design in DESIGNS if n > 1 else DESIGNS[:1]:
            start = time.perf_counter()
            flown = simulate(
                replace(fleet, fleet_integration=design), processes=processes
            )
            build = time.perf_counter() - start - flown.wall_time
            cpu, wall = speeds(flown)
            separation = flown.metrics.get("min_separation")
            vehicles = [flown, *flown.others]
            # Separate integration: a vehicle's steps (the mean); one
            # integrator: the fleet's.
            steps = np.mean([f.integrator_steps for f in vehicles])
            row = {
                "n": n,
                "design": design,
                "cpu": cpu,
                "wall": wall,
                "cpu_ref": cpu_ref,
                "ratio": cpu / cpu_ref,
            }
            rows.append(row)
            sep = "–" if separation is None else f"{separation:.3f}"
            label = "one vehicle" if n == 1 else design
            built = f"{build:.1f}" if design == "one" else "–"
            say(
                lines,
                f"| {n} | {label} | {flown.metrics['outcome']} | {sep} | {steps:.0f} "
                f"| {cpu:.1f} | {wall:.1f} | {cpu_ref:.1f} | {wall_ref:.1f} "
                f"| {cpu / cpu_ref:.2f} | {wall / wall_ref:.2f} | {built} |",
            )
    return rows


def compiled_scaling(
    sizes: list[int], seed: int, field_seconds: float, lines: list[str]
) -> None:
    """The one-integrator fleet against a lone compiled vehicle, in empty
    space and among static obstacles (the module docstring's "Compiled")."""
    say(
        lines,
        "| scene | N | outcome | steps | vehicle-s per CPU s | alone: per CPU s "
        "| ratio (CPU) | realtime factor: flight | whole call |",
    )
    say(lines, "|---|---|---|---|---|---|---|---|---|")
    field = generator.random_field(seed, 0, 0.1)
    for scene in ("empty", "obstacles"):
        for n in sizes:
            if scene == "empty":
                fleet = antipodal_circle(max(n, 2))
                label = f"circle ({len(fleet.obstacles)} obstacles)"
            else:
                fleet = random_pairs(field, max(n, 2), seed, 0)
                fleet = replace(fleet, duration=field_seconds)
                label = f"field {seed}/0 ({len(fleet.obstacles)} obstacles)"
            lone = replace(alone(fleet), engine="compiled")
            references = [speeds(simulate(lone))[0] for _ in range(3)]
            reference = float(np.median(references))
            # N = 1: the lone vehicle's own row (its ratio: the spread).
            fleet = replace(fleet, fleet_integration="one") if n > 1 else lone
            start = time.perf_counter()
            flown = simulate(fleet)
            whole = time.perf_counter() - start
            cpu = speeds(flown)[0]
            sim_time = flown.metrics["sim_time"]
            say(
                lines,
                f"| {label} | {n} | {flown.metrics['outcome']} "
                f"| {flown.integrator_steps} | {cpu:.1f} | {reference:.1f} "
                f"| {cpu / reference:.2f} | {sim_time / flown.wall_time:.1f} "
                f"| {sim_time / whole:.1f} |",
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
        # One integrator: the vehicles see each other with no exchange at all.
        flown["one integrator"] = simulate(
            replace(scene, fleet_integration="one")
        ).metrics
        for r, m in flown.items():
            path = np.array([v["path_length"] for v in m["vehicles"]])
            diff = np.abs(path - paths[max(hz)]).max()
            rate = r if isinstance(r, str) else f"{r:g}"
            say(
                lines,
                f"| {scene.name} | {rate} | {m['outcome']} "
                f"| {m['min_separation']:.3f} | {listed(path)} | {diff:.3f} |",
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

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for design, marker in zip(DESIGNS, "o^", strict=True):
        # The lone vehicle (N = 1) starts both curves.
        mine = [r for r in rows if r["design"] == design or r["n"] == 1]
        n = [r["n"] for r in mine]
        label = {"separate": "separate integration", "one": "one integrator"}[design]
        ax.plot(n, [r["cpu"] for r in mine], marker + "-", label=f"{label}, per CPU s")
    reference = [r for r in rows if r["design"] == DESIGNS[0]]
    n = [r["n"] for r in reference]
    ax.plot(n, [r["cpu_ref"] for r in reference], "s--", label="one vehicle alone")
    ax.plot(n, [0.75 * r["cpu_ref"] for r in reference], ":", label="0.75 × alone")
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
    parser.add_argument("--compiled", default="", help="sizes, e.g. 1,8,16,32")
    parser.add_argument("--field-seed", type=int, default=0)
    parser.add_argument("--field-seconds", type=float, default=20.0)
    parser.add_argument("--figure", default="")
    parser.add_argument(
        "--page",
        help="a page to write the tables into (sections fleet_scaling, "
        "fleet_compiled, fleet_rates, fleet_rule)",
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
        if args.figure:
            figure(rows, args.figure)
        if args.page:
            write_section(args.page, "fleet_scaling", "\n".join(lines))
    compiled = [int(n) for n in args.compiled.split(",") if n]
    if compiled:
        start, load = time.perf_counter(), os.getloadavg()[0]
        lines = [f"1 process, {os.cpu_count()} cores, load average {load:.1f}:", ""]
        compiled_scaling(compiled, args.field_seed, args.field_seconds, lines)
        lines += ["", f"The whole command: {time.perf_counter() - start:.0f} s."]
        print(lines[-1], flush=True)
        if args.page:
            write_section(args.page, "fleet_compiled", "\n".join(lines))
    if args.rates:
        lines, rule_lines = [], []
        rates([float(r) for r in args.rates.split(",")], lines, rule_lines)
        if args.page:
            write_section(args.page, "fleet_rates", "\n".join(lines))
            write_section(args.page, "fleet_rule", "\n".join(rule_lines))


if __name__ == "__main__":
    main()
