"""The closed loop linearised at hover at its goal.

`build_analysis_diagram` is the flight diagram without SceneGraph: the same
QuadrotorPlant, navigator, goal attraction (eq 21's PD mode fixed), attitude
PD (eq 25) and mixer, with nothing seen. It is a plain Drake Diagram:
`linearize_closed_loop` is Drake's `Linearize` on it (AutoDiffXd), checked
here against central finite differences of the float diagram. The
eigenvalues say how the vehicle settles at its goal; a LinearSystem of A,
flown from an offset beside the diagram itself, shows how far that holds.

    python examples/analysis.py [--vehicle drake_default] [--duration 5]

Prints the eigenvalues with their damping ratios, |A_Linearize − A_fd| and
the linear model's error along the flight; exits with status 1 if the loop
is not stable.
"""

import argparse
import sys

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.primitives import LinearSystem

from mfi_drake import (
    NavigationConfig,
    build_analysis_diagram,
    finite_difference_jacobian,
    hover_modes,
    hover_state,
    linearize_closed_loop,
)

GOAL = [0.0, 0.0, 1.5]
OFFSET = np.array([0.3, -0.2, 0.1, 0.0, 0.0, 0.2, 0, 0, 0, 0, 0, 0])  # m, rad


def flown(system, x0: np.ndarray, duration: float) -> np.ndarray:
    """`system`'s continuous state after `duration` s from x0."""
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    context.SetContinuousState(x0)
    simulator.AdvanceTo(duration)
    return context.get_continuous_state_vector().CopyToVector()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--vehicle", default="drake_default")
    parser.add_argument("--duration", type=float, default=5.0, help="s")
    args = parser.parse_args()

    analysis = build_analysis_diagram(NavigationConfig(goal=GOAL, vehicle=args.vehicle))
    x0 = hover_state(analysis.goal)  # level, at rest, at the goal
    A = linearize_closed_loop(analysis, x0)
    A_fd = finite_difference_jacobian(analysis.diagram, x0)
    eigenvalues = np.linalg.eigvals(A)
    eigenvalues = eigenvalues[np.lexsort((eigenvalues.imag, eigenvalues.real))]
    modes = hover_modes(eigenvalues)
    print(f"{args.vehicle}: closed loop at hover at {GOAL}, eq 21's PD mode")
    for e, zeta in zip(eigenvalues, modes["damping_ratios"], strict=True):
        print(f"  eigenvalue {e.real:+9.4f} {e.imag:+9.4f}j  damping {zeta:.3f}")
    print(
        f"max real part {modes['max_real_part']:+.4f} 1/s, slowest time constant "
        f"{modes['slowest_time_constant']:.3f} s"
    )
    print(f"|A_Linearize - A_fd| max {np.abs(A - A_fd).max():.2e}")

    # Beside the diagram itself, the linear model from the same offset.
    linear = LinearSystem(A, np.zeros((12, 0)), np.eye(12), np.zeros((12, 0)))
    x = flown(analysis.diagram, x0 + OFFSET, args.duration)
    dx = flown(linear, OFFSET, args.duration)
    print(
        f"after {args.duration:g} s from |offset| {np.linalg.norm(OFFSET):.3f}: "
        f"|x - x0| {np.linalg.norm(x - x0):.2e}, linear model off by "
        f"{np.linalg.norm(x - x0 - dx):.2e}"
    )
    return 0 if modes["max_real_part"] < 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
