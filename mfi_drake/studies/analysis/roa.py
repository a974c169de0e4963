"""The region of attraction of the PD mode (eq 20–25): an SOS certificate on
the reduced polynomial model (`maths.reduced_models`), that model's sampled
boundary, and sampled starts of the full vehicle."""

import time

import numpy as np
from pydrake.solvers import ScsSolver
from pydrake.symbolic import Evaluate, Jacobian, Variable
from pydrake.systems.analysis import (
    RegionOfAttraction,
    RegionOfAttractionOptions,
    Simulator,
)
from pydrake.systems.framework import EventStatus
from pydrake.systems.primitives import SymbolicVectorSystem

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import as_vehicle
from mfi_drake.flight.analysis_diagram import (
    AnalysisDiagram,
    build_analysis_diagram,
    hover_state,
)
from mfi_drake.maths import fields
from mfi_drake.maths.constants import GRAVITY
from mfi_drake.maths.quadcopter import attitude_gains
from mfi_drake.maths.reduced_models import reduced_terminal_dynamics, rk4_step


def reduced_model_constants(scenario: Scenario) -> dict:
    """The constants of `reduced_terminal_dynamics` for `scenario`: a, b of
    eq 25 on the pitch axis (it drives x)."""
    vehicle = as_vehicle(scenario.vehicle)
    params = for_vehicle(scenario.navigator, vehicle)
    K_Ptheta, K_Dtheta = attitude_gains(vehicle, params)
    J = np.asarray(vehicle.inertia)
    return {
        "m": vehicle.mass,
        "K_P": params.K_P,
        "K_D": params.K_D,
        "K_Pv": params.K_Pv,
        "a": float(K_Ptheta[1] / J[1]),
        "b": float(K_Dtheta[1] / J[1]),
    }


def certified_quadratic(
    variables: list[Variable],
    dynamics: list,
    scales: np.ndarray | None = None,
    time_scale: float = 1.0,
) -> np.ndarray:
    """S with {xᵀ S x ≤ 1} in the region of attraction of x = 0, certified by
    Drake's `RegionOfAttraction` (SOS, SCS solver) for ẋ = dynamics(x)
    polynomial in `variables`.

    The program is posed in the coordinates z = diag(scales) x and the time
    time_scale · t (both only for the solver's conditioning); the Lyapunov
    candidate is Drake's default there, the quadratic from the Lyapunov
    equation of the linearisation, and the SOS program finds its largest
    certified level set, mapped back to x here.
    """
    scales = np.ones(len(variables)) if scales is None else np.asarray(scales)
    z = [Variable(f"z{i}") for i in range(len(variables))]
    back = {x: z_i / d for x, z_i, d in zip(variables, z, scales, strict=True)}
    scaled = [
        (d * f).Substitute(back) / time_scale
        for d, f in zip(scales, dynamics, strict=True)
    ]
    system = SymbolicVectorSystem(state=z, dynamics=scaled)
    options = RegionOfAttractionOptions()
    options.state_variables = np.array(z)
    options.solver_id = ScsSolver.id()
    V = RegionOfAttraction(system, system.CreateDefaultContext(), options)
    S_z = 0.5 * Evaluate(Jacobian(Jacobian([V], z)[0], z))
    return np.diag(scales) @ S_z @ np.diag(scales)


def roa_sos(scenario: Scenario) -> dict:
    """The SOS certificate on the reduced model, as a ball of (e, v) offsets at
    θ = ω = 0, and the part of it where the model has no saturation.

    Scaling for the solver: the tilt and its rate in metres of the position
    error that tilt balances (m g/(K_Pv K_P) per rad, and per rad/s over
    ω_n), time in units of 1/√(ω_p ω_n), ω_p = √(K_P/m), ω_n = √a.
    """
    c = reduced_model_constants(scenario)
    params = for_vehicle(scenario.navigator, as_vehicle(scenario.vehicle))
    variables = [Variable(n) for n in ("e", "v", "theta", "omega")]
    metres_per_rad = c["m"] * GRAVITY / (c["K_Pv"] * c["K_P"])
    omega_n = np.sqrt(c["a"])
    start = time.perf_counter()
    S = certified_quadratic(
        variables,
        reduced_terminal_dynamics(variables, **c),
        scales=np.array([1.0, 1.0, metres_per_rad, metres_per_rad / omega_n]),
        time_scale=float(np.sqrt(np.sqrt(c["K_P"] / c["m"]) * omega_n)),
    )
    seconds = time.perf_counter() - start
    S_ev = np.linalg.eigvalsh(S[:2, :2]).max()
    radius = float(1.0 / np.sqrt(S_ev))
    # Sublevel sets {V ≤ ρ} are invariant; on one, |θ| ≤ √(ρ (S⁻¹)_θθ) and
    # |K_P e + K_D v| ≤ √(ρ kᵀ S⁻¹ k). The largest ρ ≤ 1 keeping both inside
    # the tilt limit and the |F_pd| saturation, and the ball it contains:
    S_inv = np.linalg.inv(S)
    k = np.array([params.K_P, params.K_D, 0.0, 0.0])
    rho = min(
        1.0, params.max_tilt**2 / S_inv[2, 2], params.max_pd_force**2 / (k @ S_inv @ k)
    )
    return {
        "radius": float(np.sqrt(rho / S_ev)),
        "radius_reduced_model": radius,
        "units": "norm of the offset (Δp [m], Δv [m/s]) from hover at the goal",
        "model": (
            "reduced 4-state polynomial model of one horizontal axis in PD "
            "mode (e, v, θ, ω), tan/cos to 3rd order, no saturation "
            "(maths.reduced_models.reduced_terminal_dynamics)"
        ),
        "method": (
            "Drake RegionOfAttraction (SOS, SCS solver), Lyapunov candidate "
            "from the (scaled) linearisation, certifying {V ≤ 1}; "
            "radius_reduced_model = largest (e, v) disc at θ = ω = 0 inside it; "
            "radius = the same inside the largest certified sublevel set "
            "{V ≤ ρ} on which |θ| ≤ max_tilt and |F_pd| ≤ max_pd_force, where "
            "the reduced model is the vehicle's controller"
        ),
        "rho_without_saturation": float(rho),
        "lyapunov_S": S.tolist(),
        "max_tilt_in_certified_set": float(np.sqrt(S_inv[2, 2])),
        "max_pd_force_in_certified_set": float(np.sqrt(k @ S_inv @ k)),
        "solve_seconds": seconds,
    }


def reduced_model_boundary(
    scenario: Scenario,
    angles: np.ndarray,
    largest: float = 100.0,
    horizon: float = 40.0,
    iterations: int = 14,
) -> np.ndarray:
    """For each direction angle in the (e, v) plane (θ = ω = 0), the radius
    (≤ `largest`) up to which the reduced model converges, by bisection
    along the ray (so it assumes the region is star-shaped along rays).
    All rays at once: vectorised RK4, 5 ms steps; converged: |x| < 1e-3
    after `horizon` seconds."""
    constants = reduced_model_constants(scenario)
    h = 5e-3

    def dynamics(x: np.ndarray) -> np.ndarray:
        return np.array(reduced_terminal_dynamics(x, **constants))

    def converged(radius: np.ndarray) -> np.ndarray:
        zero = np.zeros_like(radius)
        x = np.array([radius * np.cos(angles), radius * np.sin(angles), zero, zero])
        with np.errstate(all="ignore"):
            for _ in range(int(horizon / h)):
                x = np.clip(rk4_step(dynamics, x, h), -1e6, 1e6)
            return np.all(np.abs(x) < 1e-3, axis=0)

    low = np.zeros(len(angles))
    high = np.full(len(angles), largest)
    inside = converged(high)
    low[inside] = largest
    for _ in range(iterations if not inside.all() else 0):
        mid = 0.5 * (low + high)
        ok = converged(mid)
        low = np.where(ok & ~inside, mid, low)
        high = np.where(ok | inside, high, mid)
    return low


def roa_directions(seed: int = 5, random: int = 8) -> np.ndarray:
    """Unit 6-vectors (Δp, Δv): 8 in the (Δx, Δv_x) plane, ± each other axis,
    and `random` seeded random ones."""
    plane = [
        np.r_[np.cos(q), 0, 0, np.sin(q), 0, 0]
        for q in np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ]
    axes = [s * np.eye(6)[i] for i in (1, 2, 4, 5) for s in (1.0, -1.0)]
    rng = np.random.default_rng(seed)
    others = rng.normal(size=(random, 6))
    others /= np.linalg.norm(others, axis=1, keepdims=True)
    return np.vstack([plane, axes, others])


def converges_from(
    analysis: AnalysisDiagram, offset: np.ndarray, tolerance: float = 1e-2
) -> bool:
    """Whether the PD-mode vehicle started at hover + offset (Δp, Δv) reaches
    |Δp|, |Δv| < tolerance within 30 s + 3 s per unit of |offset|, without
    rolling or pitching past 90°."""
    goal = analysis.goal
    simulator = Simulator(analysis.diagram)
    context = simulator.get_mutable_context()
    x0 = hover_state(goal)
    x0[0:3] += offset[0:3]
    x0[6:9] += offset[3:6]
    context.SetContinuousState(analysis.state(x0))
    outcome = {}

    def monitor(root_context):
        x = root_context.get_continuous_state_vector().CopyToVector()
        if not np.all(np.isfinite(x)) or np.abs(x[3:5]).max() >= np.pi / 2:
            outcome["converged"] = False
        elif (
            np.linalg.norm(x[0:3] - goal) < tolerance
            and np.linalg.norm(x[6:9]) < tolerance
        ):
            outcome["converged"] = True
        else:
            return EventStatus.Succeeded()
        return EventStatus.ReachedTermination(analysis.diagram, "decided")

    simulator.set_monitor(monitor)
    try:
        simulator.AdvanceTo(30.0 + 3.0 * np.linalg.norm(offset))
    except RuntimeError:
        return False
    return outcome.get("converged", False)


def roa_sampled(scenario: Scenario, radii: np.ndarray, directions: np.ndarray):
    """The largest radius on `radii` such that every start on every sphere up
    to it (one start per direction) converges; stops at the first failure."""
    analysis = build_analysis_diagram(scenario, fields.MODE_PD)
    results, radius = [], 0.0
    start = time.perf_counter()
    for r in radii:
        outcomes = [converges_from(analysis, r * d) for d in directions]
        results.append(outcomes)
        if not all(outcomes):
            break
        radius = float(r)
    return {
        "radius": radius,
        "lower_bound_only": len(results) == len(radii) and all(results[-1]),
        "largest_radius_tried": float(radii[len(results) - 1]),
        "units": "norm of the offset (Δp [m], Δv [m/s]) from hover at the goal",
        "model": (
            "full nonlinear 12-state vehicle: QuadrotorPlant with the MFI "
            "navigator, PD-mode selector (eq 20, |F_pd| ≤ max_pd_force), attitude "
            "PD with tilt limit, saturating mixer"
        ),
        "method": (
            f"{len(directions)} directions (8 in the (Δx, Δv_x) plane, ± the other "
            "axes, seeded random) on spheres of radii "
            f"{[float(r) for r in radii]}; converged = |Δp|, |Δv| < 1 cm(/s) "
            "before 30 s + 3 s per unit radius, attitude never past 90°"
        ),
        "outcomes": results,
        "seconds": time.perf_counter() - start,
    }
