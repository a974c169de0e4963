"""Symmetric conflicts: N vehicles meeting head-on in the middle of an
antipodal circle (docs/fleets.md, "Symmetric conflicts").

    python benchmarks/fleet_conflicts.py [--sizes 2,3,4,8,16,32]
                                         [--methods mfi,mfi-paper,apf,gf]
                                         [--keep-right 0,60] [--processes P]
                                         [--page docs/dynamic.md]

Every method flies the same circles (`world.fleets.antipodal_circle`; a
fleet ends at its first contact) with each angle of the rule of the road
listed (`relative_velocity.keep_right`; 0: none; by default none and the
scenario default). Printed per circle and method, for each angle: the
outcome (a time-out with the vehicles short of their goals: deadlocks), the
least separation, and the side each vehicle chose: the sign of its angular
momentum about the circle's centre, (p × v)_z summed over the logged steps
while it is within 2 m of the centre: + it went round anticlockwise seen
from above (the centre on its left: it swerved right), − clockwise (it
swerved left). Every vehicle on one side: a roundabout.
"""

import argparse
import itertools
import os
from dataclasses import replace

import numpy as np

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.files import write_section
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.fleets import antipodal_circle

MEETING = 2.0  # [m] from the centre: where a vehicle's side is read


def side(flight) -> int:
    """+1 anticlockwise, −1 clockwise, 0 straight through the middle."""
    p, v = flight.positions, flight.log["state"][:, 6:9]
    near = np.hypot(p[:, 0], p[:, 1]) < MEETING
    turn = np.sum(p[near, 0] * v[near, 1] - p[near, 1] * v[near, 0])
    return int(np.sign(round(turn, 6)))


def conflict(flight) -> str:
    """A table cell: the outcome (with the vehicles deadlocked short of their
    goals, if any), the least separation, and each vehicle's side."""
    m = flight.metrics
    result = m["outcome"]
    if result == "timeout":
        result += f" ({sum(not v['reached'] for v in m['vehicles'])} short)"
    sides = "".join(
        {1: "+", -1: "−", 0: "0"}[side(f)] for f in (flight, *flight.others)
    )
    return f"{result}, {m['min_separation']:.3f}, {sides}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2,3,4,8,16,32")
    parser.add_argument("--methods", default="mfi,mfi-paper,apf,gf")
    parser.add_argument("--keep-right", default=f"0,{RelativeVelocity.keep_right:g}")
    parser.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--page", help="a page to write the table into (section fleet_conflicts)"
    )
    args = parser.parse_args(argv)
    turns = [float(k) for k in args.keep_right.split(",")]
    header = "| N | method | " + " | ".join(
        f"rule {t:g}°: outcome, least separation [m], sides" for t in turns
    )
    lines = [header + " |", "|---|---|" + "---|" * len(turns)]
    print("\n".join(lines), flush=True)
    for n, method in itertools.product(
        [int(k) for k in args.sizes.split(",")], args.methods.split(",")
    ):
        scene = antipodal_circle(n)
        cells = []
        for turn in turns:
            rule = replace(scene.relative_velocity, keep_right=turn)
            flight = simulate(
                replace(scene, relative_velocity=rule),
                method,
                stop_at_contact=True,
                processes=args.processes,
            )
            cells.append(conflict(flight))
        lines.append(f"| {n} | {method} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    if args.page:
        write_section(args.page, "fleet_conflicts", "\n".join(lines))


if __name__ == "__main__":
    main()
