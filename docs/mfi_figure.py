"""The README's picture of MFI: one flight past a sphere, seen from above,
with what the navigator computed at three moments of it.

    python docs/mfi_figure.py [--out docs/figures/mfi_idea.png]

The default MFI flies the planar wall's start to its goal, (0, 0) to
(8, 0), past a sphere of radius 1 m at (4, 0.25), 1.5 m up. At three logged
steps the figure draws the velocity v, the artificial current l_o on the
obstacle at its closest point (eq 11: the heading projected on the surface)
and the boundary-following force F that the navigator logged (eq 12, ⟂ v).
"""

import argparse
import os

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from mfi_drake import load_scenario, simulate
from mfi_drake.app.figures import write_figure
from mfi_drake.maths.layout import POSITION, READING_SIZE, VELOCITY

# The planar wall's start, goal and vehicle, its wall replaced by a sphere.
LAYER = """
duration: 20.0
obstacles:
  - {shape: !Sphere {radius: 1.0}, position: [4.0, 0.25, 1.5], rpy_deg: [0, 0, 0]}
"""
CENTRE, RADIUS = np.array([4.0, 0.25]), 1.0
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fly():
    path = os.path.join(ROOT, "scenarios", "planar_wall.yaml")
    return simulate(load_scenario(path, [("mfi_idea", LAYER)]), "mfi")


def draw(flight, out: str) -> None:
    log = flight.log
    state = np.asarray(log["state"])
    state = state if state.shape[-1] == 12 else state.T
    reading = np.asarray(log["obstacle"])
    reading = reading if reading.shape[-1] == 3 * READING_SIZE else reading.T
    terms = np.asarray(log["obstacle_force_terms"])
    terms = terms if terms.shape[-1] == 6 else terms.T
    p, v, F = state[:, POSITION], state[:, VELOCITY], terms[:, :3]
    fig = Figure(figsize=(8.0, 3.6))
    ax = fig.subplots()
    ax.add_patch(Circle(CENTRE, RADIUS, color="0.75", label="obstacle"))
    ax.plot(p[:, 0], p[:, 1], color="tab:blue", label="path flown by MFI")
    ax.plot(*p[0, :2], "o", color="tab:blue")
    ax.plot(8.0, 0.0, "*", color="tab:green", markersize=14, label="goal")
    # Three moments where the boundary-following force is at work.
    strength = np.linalg.norm(F, axis=1)
    working = np.flatnonzero(strength > 0.05 * strength.max())
    for i in working[[len(working) // 6, len(working) // 2, -1]]:
        speed = np.linalg.norm(v[i])
        r_o = reading[i, :3]
        n = r_o / np.linalg.norm(r_o)
        l_a = v[i] / speed
        l_o = l_a - (l_a @ n) * n  # eq 11
        point = p[i] + r_o
        ax.annotate(
            "", p[i, :2] + 0.6 * l_a[:2], p[i, :2],
            arrowprops={"arrowstyle": "->", "color": "tab:blue", "lw": 2},
        )  # fmt: skip
        ax.annotate(
            "", point[:2] + 0.6 * l_o[:2], point[:2],
            arrowprops={"arrowstyle": "->", "color": "tab:orange", "lw": 2},
        )  # fmt: skip
        ax.annotate(
            "", p[i, :2] + 0.6 * F[i, :2] / strength[i], p[i, :2],
            arrowprops={"arrowstyle": "->", "color": "tab:red", "lw": 2},
        )  # fmt: skip
    for colour, label in (
        ("tab:blue", "velocity v"),
        ("tab:orange", "current l_o on the obstacle (eq 11)"),
        ("tab:red", "force F, perpendicular to v (eq 12)"),
    ):
        ax.plot([], [], color=colour, lw=2, label=label)
    ax.set_aspect("equal")
    ax.set_xlim(-0.5, 8.8)
    ax.set_ylim(-1.6, 2.4)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("MFI seen from above: the current round the obstacle turns v")
    ax.legend(loc="upper left", fontsize=8, ncol=2)
    fig.tight_layout()
    write_figure(fig, out)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("--out", default="docs/figures/mfi_idea.png")
    args = parser.parse_args()
    draw(fly(), args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
