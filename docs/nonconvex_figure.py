"""docs/nonconvex.md's picture: a top view of one world of each class of
`world.nonconvex`, with the paths of MFI with and without its escape rule.

    python docs/nonconvex_figure.py [--index 0] [--out docs/figures/nonconvex.png]

World `index` of seed 0 of every class, flown by "mfi-memoryless" and "mfi" as a
sweep ends a flight (at rest at the goal, or at contact). Each panel is a
section at the flight height: the footprint of every obstacle that spans
the start's height (ceilings and lintels, which would hide the rooms, are
left out), the start (circle), the goal (star) and each path with its
outcome.
"""

import argparse
import dataclasses
import os

from matplotlib.figure import Figure

from mfi_drake import simulate
from mfi_drake.app.figures import draw_footprints, write_figure
from mfi_drake.flight.methods import appearance
from mfi_drake.studies.sweep import SWEEP_ENDS
from mfi_drake.world.nonconvex import KINDS, nonconvex_world
from mfi_drake.world.obstacles import obstacle_triangles

METHODS = ("mfi-memoryless", "mfi")


def section(world):
    """`world` with only the obstacles whose height range holds the start's."""
    height = world.start[2]
    kept = []
    for obstacle in world.obstacles:
        z = obstacle_triangles(world, obstacle)[:, :, 2]
        if z.min() <= height <= z.max():
            kept.append(obstacle)
    return dataclasses.replace(world, obstacles=kept)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--index", type=int, default=0)
    parser.add_argument("--out", default="docs/figures/nonconvex.png")
    args = parser.parse_args()
    fig = Figure(figsize=(12, 8))
    for k, kind in enumerate(KINDS):
        world = nonconvex_world(kind, 0, args.index)
        ax = fig.add_subplot(2, 3, k + 1)
        draw_footprints(ax, section(world))
        for method in METHODS:
            flight = simulate(world, method, **SWEEP_ENDS)
            label, colour = appearance(method)
            outcome = flight.metrics["outcome"]
            ax.plot(*flight.positions[:, :2].T, color=colour, lw=1.2)
            ax.plot([], [], color=colour, label=f"{label}: {outcome}")
        ax.plot(*world.start[:2], "o", color="k")
        ax.plot(*world.goal[:2], "*", color="k", ms=10)
        ax.set_title(world.name, fontsize=9)
        ax.set_aspect("equal")
        ax.autoscale()
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    write_figure(fig, args.out)


if __name__ == "__main__":
    main()
