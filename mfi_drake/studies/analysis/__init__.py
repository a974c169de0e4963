"""Linearisation and stability analysis of the closed loop (issue 5).

On the analysis diagram (`flight.analysis_diagram`: the flight diagram
without SceneGraph, no obstacle seen, eq 21's mode fixed):
- `linearization`: the plant at hover, A, B and its controllability (eq 7
  linearised); the closed loop at hover at the goal in PD mode (eq 20–25):
  eigenvalues, damping, Drake's `Linearize` against central finite
  differences; a root-locus sweep of K_P, K_D (eq 20) and K_Pθ, K_Dθ (eq 25);
- `cruise`: along a simulated flight, the power of the zero-work terms F,
  F_a, F_gc (eq 12, 14, 18) at field level and as the vehicle realises them,
  the cruise speed (eq 19) and the heading decay of eq 17;
- `roa`: the region of attraction of the PD mode, an SOS certificate on a
  reduced polynomial model (`maths.reduced_models`) and sampled starts of
  the full vehicle;
- `report`: `run_analysis` runs them all, `summary` words the report.
"""

from mfi_drake.studies.analysis.report import run_analysis, summary

__all__ = ["run_analysis", "summary"]
