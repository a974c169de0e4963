"""How the APF and GF default gains were chosen (docs/comparison.md).

Flies every gain set of a fixed grid on the four paper scenarios and ranks
the sets by a key fixed before looking at any result:
  1. most successes (goal reached, no collision),
  2. fewest collisions,
  3. least total time to the goal (an unreached goal counts the whole flight),
  4. least total final distance to the goal.
Prints the ranking's top rows per method as Markdown. MFI is not tuned here.
Run from the repository root: `python docs/tune_baselines.py` (~30 min).
"""

import itertools
import os
import sys
from dataclasses import replace

from mfi_drake.config.parameters import ApfParams, AttractionParams, GfParams
from mfi_drake.flight.simulation import simulate
from mfi_drake.studies.compare import PAPER_SCENARIOS
from mfi_drake.world.validation import load_scenario

# (k_att, k_d) pairs, all with v_max = MFI's v_d = 1 m/s: the same cruise
# speed for every method; the first pair is MFI's own eq 20 gains.
ATTRACTIONS = [
    AttractionParams(1.5, 2.0, 1.0),
    AttractionParams(0.75, 1.0, 1.0),
    AttractionParams(0.375, 0.5, 1.0),
]
APF_GRID = [
    ApfParams(attraction=a, eta=eta, rho_0=rho_0)
    for a, eta, rho_0 in itertools.product(
        ATTRACTIONS, [0.02, 0.05, 0.1, 0.2, 0.5], [0.3, 0.5, 1.0, 1.5]
    )
]
GF_GRID = [
    GfParams(attraction=a, k_g=k_g, r_d=r_d, eta=eta, rho_0=rho_0)
    for a, k_g, r_d, (eta, rho_0) in itertools.product(
        ATTRACTIONS,
        [4.0, 8.0, 16.0, 32.0],
        [0.75, 1.0, 1.5, 2.0],
        [(0.01, 0.3), (0.02, 0.4), (0.05, 0.5)],
    )
]

# Second stage: the first grid's best sets sat on its edges (stiffest
# repulsion for APF; latest, strongest steering for GF), so the grid goes on
# past them.
APF_GRID += [
    ApfParams(attraction=ATTRACTIONS[1], eta=eta, rho_0=rho_0)
    for eta, rho_0 in itertools.product([0.5, 1.0], [0.2])
] + [ApfParams(attraction=ATTRACTIONS[1], eta=1.0, rho_0=0.3)]
GF_GRID += [
    GfParams(attraction=ATTRACTIONS[0], k_g=k_g, r_d=r_d, eta=eta, rho_0=rho_0)
    for k_g, r_d, (eta, rho_0) in itertools.product(
        [32.0, 64.0], [0.5, 0.75], [(0.005, 0.2), (0.01, 0.3)]
    )
    if (k_g, r_d, eta) != (32.0, 0.75, 0.01)  # already in the first grid
]


def score(metrics: list[dict]) -> tuple:
    """The ranking key (smaller is better)."""
    return (
        -sum(m["success"] for m in metrics),
        sum(m["collided"] for m in metrics),
        sum(m["convergence_time"] or m["sim_time"] for m in metrics),
        sum(m["final_error"] for m in metrics),
    )


def tune(method: str, grid: list, scenarios: list) -> list[tuple[tuple, object]]:
    ranked = []
    for i, params in enumerate(grid):
        metrics = [
            simulate(replace(s, **{method: params}), method).metrics for s in scenarios
        ]
        ranked.append((score(metrics), params))
        print(f"{method} {i + 1}/{len(grid)} {ranked[-1][0]}", file=sys.stderr)
    return sorted(ranked, key=lambda item: item[0])


def main() -> None:
    scenarios = [
        load_scenario(os.path.join("scenarios", f"{name}.yaml"))
        for name in PAPER_SCENARIOS
    ]
    for method, grid in (("apf", APF_GRID), ("gf", GF_GRID)):
        print(f"\n{method}: {len(grid)} gain sets, best first\n")
        print("| successes | collisions | Σ time [s] | Σ final error [m] | gains |")
        print("|---|---|---|---|---|")
        for key, params in tune(method, grid, scenarios)[:8]:
            print(f"| {-key[0]} | {key[1]} | {key[2]:.1f} | {key[3]:.2f} | {params} |")


if __name__ == "__main__":
    main()
