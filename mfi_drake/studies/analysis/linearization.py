"""The closed loop linearised: the plant at hover (eq 7), the PD-mode loop at
hover at the goal (eq 20–25) by Drake's `Linearize` against central finite
differences, and a root-locus sweep of K_P, K_D (eq 20) and K_Pθ, K_Dθ
(eq 25)."""

import dataclasses

import numpy as np
from pydrake.systems.framework import Diagram
from pydrake.systems.primitives import Linearize

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.analysis_diagram import (
    AnalysisDiagram,
    build_analysis_diagram,
    hover_state,
    time_derivatives,
)
from mfi_drake.flight.diagram import make_plant
from mfi_drake.maths import fields
from mfi_drake.maths.quadcopter import attitude_gains

STATE_NAMES = ["x", "y", "z", "roll", "pitch", "yaw"] + [
    f"d{n}" for n in ("x", "y", "z", "roll", "pitch", "yaw")
]
# The gains of the root-locus sweep: eq 20's K_P, K_D and eq 25's K_Pθ, K_Dθ.
SWEPT_GAINS = ("K_P", "K_D", "K_Ptheta", "K_Dtheta")


def linearize_closed_loop(analysis: AnalysisDiagram, x0: np.ndarray) -> np.ndarray:
    """A of the closed loop at x0 by Drake's `Linearize` (AutoDiffXd). x0:
    the whole continuous state, or the plant's 12-state (`analysis.state`:
    the motors' lag, where the vehicle has one, at hover)."""
    context = analysis.diagram.CreateDefaultContext()
    context.SetContinuousState(analysis.state(x0))
    # Norms of zero vectors (v at hover, the tilt command) have infinite
    # derivatives; they are only compared, never used, so their floating-
    # point flags are not warnings here.
    with np.errstate(divide="ignore", invalid="ignore"):
        return Linearize(analysis.diagram, context).A()


def finite_difference_jacobian(
    diagram: Diagram, x0: np.ndarray, step: float = 1e-6
) -> np.ndarray:
    """∂ẋ/∂x at x0 by central differences of the float diagram."""
    columns = []
    for i in range(len(x0)):
        dx = np.zeros(len(x0))
        dx[i] = step
        forward = time_derivatives(diagram, x0 + dx)
        backward = time_derivatives(diagram, x0 - dx)
        columns.append((forward - backward) / (2.0 * step))
    return np.column_stack(columns)


# --- the plant at hover -----------------------------------------------------
def plant_at_hover(vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of QuadrotorPlant (eq 7) at level hover, u_i = m g / (4 kF)."""
    plant = make_plant(vehicle)
    context = plant.CreateDefaultContext()
    context.SetContinuousState(np.zeros(12))
    plant.get_input_port(0).FixValue(context, np.full(4, vehicle.hover_command))
    linear = Linearize(plant, context)
    return linear.A(), linear.B()


def reach_orders(A: np.ndarray, B: np.ndarray) -> list[int | None]:
    """For each state coordinate, the smallest k with e_i in span[B … A^k B]
    (None if never): k = 0 is driven by the rotors directly, a larger k
    is reached only through k integrations/couplings."""
    n = A.shape[0]
    blocks, orders = [B], [None] * n
    for k in range(n):
        K = np.hstack(blocks)
        rank = np.linalg.matrix_rank(K)
        for i in range(n):
            e = np.zeros((n, 1))
            e[i] = 1.0
            if orders[i] is None and np.linalg.matrix_rank(np.hstack([K, e])) == rank:
                orders[i] = k
        blocks.append(A @ blocks[-1])
    return orders


def plant_report(vehicle: Vehicle) -> dict:
    A, B = plant_at_hover(vehicle)
    n = A.shape[0]
    controllability = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(n)])
    orders = reach_orders(A, B)
    lateral = [STATE_NAMES[i] for i in (0, 1, 6, 7)]
    return {
        "A": A.tolist(),
        "B": B.tolist(),
        "controllability_rank": int(np.linalg.matrix_rank(controllability)),
        "reach_order": dict(zip(STATE_NAMES, orders, strict=True)),
        "through_attitude_only": lateral,
        "note": (
            "B drives only the vertical acceleration and the three angular "
            "accelerations; x, y and their rates enter A only through "
            f"d(dx)/d(pitch) = {A[6, 4]:+.2f} and d(dy)/d(roll) = {A[7, 3]:+.2f} "
            "m/s² per rad, so they are reached only by tilting (orders 2–3)."
        ),
    }


# --- the closed loop at hover -------------------------------------------------
def hover_modes(eigenvalues: np.ndarray) -> dict:
    """Damping ratios and time constants of a set of stable eigenvalues
    (those of the closed loop at hover, `linearize_closed_loop`)."""
    re = eigenvalues.real
    damping = -re / np.abs(eigenvalues)
    return {
        "hover_eigenvalues": [[float(e.real), float(e.imag)] for e in eigenvalues],
        "damping_ratios": [float(z) for z in damping],
        "max_real_part": float(re.max()),
        "slowest_time_constant": float(-1.0 / re.max()) if re.max() < 0 else None,
    }


def with_gains(scenario: Scenario, factors: dict[str, float]) -> tuple:
    """(scenario, attitude_K) with each gain of SWEPT_GAINS scaled by its
    factor in `factors` (default 1)."""
    params = scenario.navigator
    vehicle = as_vehicle(scenario.vehicle)
    K_Ptheta, K_Dtheta = attitude_gains(vehicle, for_vehicle(params, vehicle))
    scaled = dataclasses.replace(
        params,
        K_P=params.K_P * factors.get("K_P", 1.0),
        K_D=params.K_D * factors.get("K_D", 1.0),
    )
    attitude_K = (
        K_Ptheta * factors.get("K_Ptheta", 1.0),
        K_Dtheta * factors.get("K_Dtheta", 1.0),
    )
    return dataclasses.replace(scenario, navigator=scaled), attitude_K


def hover_matrix(scenario: Scenario, factors: dict[str, float] | None = None):
    """A of the PD-mode closed loop at hover at the goal, gains scaled."""
    scaled, attitude_K = with_gains(scenario, factors or {})
    analysis = build_analysis_diagram(scaled, fields.MODE_PD, attitude_K)
    return linearize_closed_loop(analysis, hover_state(analysis.goal))


def max_real_part(scenario: Scenario, gain: str, factor: float) -> float:
    return float(np.linalg.eigvals(hover_matrix(scenario, {gain: factor})).real.max())


def stability_boundaries(
    scenario: Scenario, gain: str, factors: np.ndarray, max_real: np.ndarray
) -> list[dict]:
    """Where the largest real part crosses zero between sampled factors,
    refined by bisection in log(factor)."""
    crossings = []
    for i in range(len(factors) - 1):
        if (max_real[i] < 0.0) == (max_real[i + 1] < 0.0):
            continue
        low, high = np.log(factors[i]), np.log(factors[i + 1])
        stable_low = max_real[i] < 0.0
        for _ in range(30):
            mid = 0.5 * (low + high)
            if (max_real_part(scenario, gain, np.exp(mid)) < 0.0) == stable_low:
                low = mid
            else:
                high = mid
        factor = float(np.exp(0.5 * (low + high)))
        crossings.append(
            {
                "factor": factor,
                "unstable": "above" if stable_low else "below",
            }
        )
    return crossings


def default_gain_values(scenario: Scenario) -> dict[str, float]:
    """The defaults of SWEPT_GAINS (attitude gains of the roll axis)."""
    vehicle = as_vehicle(scenario.vehicle)
    K_Ptheta, K_Dtheta = attitude_gains(
        vehicle, for_vehicle(scenario.navigator, vehicle)
    )
    return {
        "K_P": scenario.navigator.K_P,
        "K_D": scenario.navigator.K_D,
        "K_Ptheta": float(K_Ptheta[0]),
        "K_Dtheta": float(K_Dtheta[0]),
    }


GAIN_UNITS = {
    "K_P": "N/m",
    "K_D": "N·s/m",
    "K_Ptheta": "N·m/rad",
    "K_Dtheta": "N·m·s/rad",
}


def gain_sweep(scenario: Scenario, points: int = 81, decades: float = 2.0) -> dict:
    """Closed-loop eigenvalues at hover as each gain of SWEPT_GAINS varies
    over `decades` each side of its default (the others at default), and
    the factors where stability is lost."""
    factors = np.logspace(-decades, decades, points)
    defaults = default_gain_values(scenario)
    sweep = {}
    for gain in SWEPT_GAINS:
        eigenvalues = np.array(
            [np.linalg.eigvals(hover_matrix(scenario, {gain: f})) for f in factors]
        )
        max_real = eigenvalues.real.max(axis=1)
        crossings = stability_boundaries(scenario, gain, factors, max_real)
        for c in crossings:
            c["value"] = c["factor"] * defaults[gain]
        sweep[gain] = {
            "default": defaults[gain],
            "units": GAIN_UNITS[gain],
            "factors": factors,
            "eigenvalues": eigenvalues,
            "max_real_part": max_real,
            "stability_lost": crossings,
        }
    return sweep
