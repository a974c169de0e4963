"""`run_analysis`: every analysis of this package on one scenario, as a
JSON-ready report and the series its figures are drawn from
(`app.analysis_figures`); `summary`: the report's key numbers as text."""

import time

import numpy as np

from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.flight.analysis_diagram import (
    build_analysis_diagram,
    hover_state,
    time_derivatives,
)
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import fields
from mfi_drake.studies.analysis.cruise import cruise_report, far_goal_heading
from mfi_drake.studies.analysis.linearization import (
    finite_difference_jacobian,
    gain_sweep,
    hover_modes,
    linearize_closed_loop,
    plant_report,
)
from mfi_drake.studies.analysis.roa import (
    reduced_model_boundary,
    roa_directions,
    roa_sampled,
    roa_sos,
)


def _hover_linearisation(scenario: Scenario, report: dict) -> np.ndarray:
    """The closed loop linearised at hover in eq 21's PD mode: its modes,
    the linearisation's error against finite differences and the hover
    equilibrium's residual, added to `report`; returns the eigenvalues,
    sorted by real then imaginary part."""
    analysis = build_analysis_diagram(scenario, fields.MODE_PD)
    x0 = analysis.state(hover_state(analysis.goal))
    A = linearize_closed_loop(analysis, x0)
    A_fd = finite_difference_jacobian(analysis.diagram, x0)
    eigenvalues = np.linalg.eigvals(A)
    eigenvalues = eigenvalues[np.lexsort((eigenvalues.imag, eigenvalues.real))]
    report.update(hover_modes(eigenvalues))
    report["linearize_vs_fd_max_error"] = float(np.abs(A - A_fd).max())
    report["hover_equilibrium_residual"] = float(
        np.abs(time_derivatives(analysis.diagram, x0)).max()
    )
    return eigenvalues


def _reduced_model_roa(scenario: Scenario, report: dict) -> tuple:
    """The region of attraction of `roa_sos`'s reduced model sampled along
    36 rays, added to `report`; returns (the rays' angles, the boundary's
    radius along each)."""
    angles = np.linspace(0.0, 2 * np.pi, 36, endpoint=False)
    boundary = reduced_model_boundary(scenario, angles)
    report["roa_reduced_model_sampled"] = {
        "radius": float(boundary.min()),
        "units": report["roa_sos"]["units"],
        "model": "the same reduced model as roa_sos",
        "method": (
            f"{len(angles)} rays in the (e, v) plane at θ = ω = 0, boundary "
            "by bisection up to 100, RK4 5 ms for 40 s; converged = |x| < 1e-3"
        ),
    }
    return angles, boundary


def run_analysis(
    scenario: Scenario, roa_radii: tuple[float, ...] = (0.5, 2.0, 8.0, 32.0)
) -> tuple[dict, dict]:
    """Runs every analysis of this package on `scenario`: (the JSON-ready
    report, the series for `app.analysis_figures.write_analysis_figures`).
    Only on the systems engine: it linearises the card's diagram of
    LeafSystems, which the compiled engine does not build."""
    if scenario.engine != "systems":
        raise ScenarioError(
            f"{scenario.name}: engine = {scenario.engine!r}: analyze linearises "
            "the diagram of systems (engine: systems)"
        )
    begin = time.perf_counter()
    vehicle = as_vehicle(scenario.vehicle)
    report = {"scenario": scenario.name, "vehicle": vehicle.name}

    plant = plant_report(vehicle)
    report["plant"] = plant
    report["controllability_rank"] = plant["controllability_rank"]

    eigenvalues = _hover_linearisation(scenario, report)
    sweep = gain_sweep(scenario)
    report["gain_sweep"] = {
        gain: {
            "default": s["default"],
            "units": s["units"],
            "range": [s["default"] * s["factors"][0], s["default"] * s["factors"][-1]],
            "stability_lost": s["stability_lost"],
            "stability_lost_within_one_decade": [
                c for c in s["stability_lost"] if 0.1 <= c["factor"] <= 10.0
            ],
        }
        for gain, s in sweep.items()
    }

    flight = simulate(scenario)
    cruise = cruise_report(flight)
    report["cruise"] = {
        k: v
        for k, v in cruise["report"].items()
        if k not in ("zero_work_field_max_abs_power",)
    }
    window_series = report["cruise"]["heading"].pop("series", None)
    report["zero_work_field_max_abs_power"] = cruise["report"][
        "zero_work_field_max_abs_power"
    ]
    far = far_goal_heading(scenario)
    far_series = far.pop("series")
    report["far_goal_heading"] = far

    sos = roa_sos(scenario)
    report["roa_sos"] = sos
    radii = np.array(roa_radii)
    directions = roa_directions()
    sampled = roa_sampled(scenario, radii, directions)
    report["roa_sampled"] = {k: v for k, v in sampled.items() if k != "outcomes"}
    angles, boundary = _reduced_model_roa(scenario, report)

    series = {
        "eigenvalues": eigenvalues,
        "gain_sweep": sweep,
        "power": cruise["series"],
        "v_d": for_vehicle(scenario.navigator, vehicle).v_d,
        "heading_window": window_series,
        "far_goal_heading": far_series,
        "heading_rate": far["closed_form_rate"],
        "roa_sos": sos,
        "roa_reduced_model": (angles, boundary),
        "roa_sampled": sampled,
        "roa_radii": radii,
        "roa_directions": directions,
    }
    report["wall_time"] = time.perf_counter() - begin
    return report, series


def summary(report: dict) -> str:
    """The report's key numbers as a few human lines."""
    sweep = "; ".join(
        f"{gain} {s['default']:.3g} {s['units']}: "
        + (
            ", ".join(
                f"unstable {c['unstable']} ×{c['factor']:.3g}"
                for c in s["stability_lost"]
            )
            or "stable throughout"
        )
        for gain, s in report["gain_sweep"].items()
    )
    cruise, sos, sampled = report["cruise"], report["roa_sos"], report["roa_sampled"]
    return "\n".join(
        [
            f"{report['scenario']} [{report['vehicle']}] analysis "
            f"({report['wall_time']:.0f} s)",
            f"plant at hover: controllability rank {report['controllability_rank']}"
            f"/12; x, y and their rates only through attitude",
            f"closed loop at hover (PD): max Re λ = {report['max_real_part']:.4g} 1/s,"
            f" slowest time constant {report['slowest_time_constant']:.3g} s,"
            " Linearize vs finite differences "
            f"{report['linearize_vs_fd_max_error']:.2g}",
            f"gain sweep (×0.01…×100): {sweep}",
            f"zero-work terms: field level |P| ≤ "
            f"{report['zero_work_field_max_abs_power']:.2g} W; realised max |P| "
            + ", ".join(
                f"{k} {v:.3g} W" for k, v in cruise["realised_power_max_abs"].items()
            ),
            _speed_line(cruise["speed"]),
            f"heading decay (far goal): vehicle e-fold "
            f"{report['far_goal_heading']['vehicle_e_fold_time']:.3g} s vs m/K_ω = "
            f"{report['far_goal_heading']['closed_form_time_constant']:.3g} s",
            f"ROA (PD mode): SOS on the reduced model {sos['radius']:.3g}; sampled "
            f"full vehicle {'≥ ' if sampled['lower_bound_only'] else ''}"
            f"{sampled['radius']:.3g} (|(Δp [m], Δv [m/s])|)",
        ]
    )


def _speed_line(speed: dict) -> str:
    if "settled_min" not in speed:  # a flight too short to settle in cruise
        return f"cruise speed: never settled ({speed['cruise_time']:.2f} s in cruise)"
    return (
        f"cruise speed (settled): {speed['settled_min']:.2f}–"
        f"{speed['settled_max']:.2f} m/s for v_d = {speed['v_d']} m/s"
    )
