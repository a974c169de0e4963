"""The family test at scale (docs/vehicles.md, "Family test"): more random
quadrotors than CI flies, each through the paper's four scenes and a random
field scaled to it, and each linearised at hover.

    python benchmarks/vehicle_family.py [--vehicles 12] [--seed 7]

Prints one line a vehicle (mass, arm, thrust to weight, layout, motor lag,
its worst path over drake_default's in its lengths, its least clearance in
collision radii, its slowest hover eigenvalue) and the count of flights
that reached their goal without a collision.
"""

import argparse
import os
import sys

import numpy as np

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicle_gains import scales, similar_scenario
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.analysis.linearization import hover_matrix

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from tests.test_vehicle_family import PAPER_SCENES, family, written  # noqa: E402


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--vehicles", type=int, default=12)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    scenes = range(len(PAPER_SCENES) + 1)
    reference = [
        simulate(written(k), "mfi", until_settled=True).metrics["path_length"]
        for k in scenes
    ]
    good = flown = 0
    for v in family(args.seed, args.vehicles):
        _, lam, _ = scales(v, Scenario().navigator)
        ratios, clearances = [], []
        for k in scenes:
            m = simulate(similar_scenario(written(k), v), "mfi", until_settled=True)
            m = m.metrics
            flown += 1
            good += bool(m["reached"] and m["min_clearance"] > 0.0)
            ratios.append(m["path_length"] / lam / reference[k])
            clearances.append(m["min_clearance"] / v.collision_radius)
        A = hover_matrix(Scenario(goal=[1.0, 0.0, 1.5], vehicle=v))
        slowest = float(np.linalg.eigvals(A).real.max())
        worst = max(ratios, key=lambda r: abs(r - 1.0))
        print(
            f"{v.mass:6.3f} kg arm {v.arm_length:.3f} m T/W "
            f"{v.thrust_to_weight:.2f} {v.layout} lag "
            f"{1e3 * v.motor_time_constant:4.1f} ms: path/ref {worst:.3f}, "
            f"clearance {min(clearances):.2f} R, hover eigenvalue {slowest:+.3f}",
            flush=True,
        )
    print(f"{good} of {flown} flights reached the goal without a collision")
    return {"good": good, "flown": flown}


if __name__ == "__main__":
    main()
