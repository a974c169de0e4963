"""Symmetric conflicts: N vehicles meeting head-on in the middle of an
antipodal circle (docs/dynamic.md, "Symmetric conflicts").

    python benchmarks/fleet_conflicts.py [--sizes 2,3,4,8,16,32]
                                         [--methods mfi,mfi-paper,apf,gf]
                                         [--keep-right 0,60] [--processes P]
                                         [--page docs/dynamic.md]

Every method flies the same circles (`world.fleets.antipodal_circle`),
without the rule of the road (--keep-right 0) and with each angle listed
(`relative_velocity.keep_right`; the default's is the scenario default).
Printed per flight: the outcome, the least separation, deadlocks (vehicles
short of their goals at the end without contact), and the side each vehicle
chose: the sign of its angular momentum about the circle's centre, (p × v)_z
summed over the logged steps while it is within 2 m of the centre: + it
went round anticlockwise seen from above (the centre on its left: it
swerved right), − clockwise (it swerved left). A roundabout: every vehicle
chose the same side.
"""

import argparse
import itertools
import os
from dataclasses import replace

import numpy as np

from mfi_drake.config.dynamic import RelativeVelocity
from mfi_drake.files import write_section
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.fleets import antipodal_circle, circle_radius

MEETING = 2.0  # [m] from the centre: where a vehicle's side is read


def side(flight) -> int:
    """+1 anticlockwise, −1 clockwise, 0 straight through the middle."""
    p, v = flight.positions, flight.log["state"][:, 6:9]
    near = np.hypot(p[:, 0], p[:, 1]) < MEETING
    turn = np.sum(p[near, 0] * v[near, 1] - p[near, 1] * v[near, 0])
    return int(np.sign(round(turn, 6)))


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
    lines = [
        "| N | rule [°] | method | outcome | least separation [m] | deadlocks "
        "| sides (+ anticlockwise) | roundabout |",
        "|---|---|---|---|---|---|---|---|",
    ]
    print("\n".join(lines), flush=True)
    for n, turn, method in itertools.product(
        [int(k) for k in args.sizes.split(",")],
        [float(k) for k in args.keep_right.split(",")],
        args.methods.split(","),
    ):
        scene = antipodal_circle(n, duration=5.0 * 2.0 * circle_radius(n))
        rule = replace(scene.relative_velocity, keep_right=turn)
        scene = replace(scene, relative_velocity=rule)
        flight = simulate(scene, method, stop_at_contact=True, processes=args.processes)
        m = flight.metrics
        contact = m["outcome"] == "collision"
        deadlocks = 0 if contact else sum(not v["reached"] for v in m["vehicles"])
        sides = [side(f) for f in (flight, *flight.others)]
        shown = "".join({1: "+", -1: "−", 0: "0"}[s] for s in sides)
        roundabout = "yes" if len(set(sides)) == 1 and sides[0] != 0 else "no"
        lines.append(
            f"| {n} | {turn:g} | {method} | {m['outcome']} "
            f"| {m['min_separation']:.3f} "
            f"| {deadlocks} | {shown} | {roundabout} |"
        )
        print(lines[-1], flush=True)
    if args.page:
        write_section(args.page, "fleet_conflicts", "\n".join(lines))


if __name__ == "__main__":
    main()
