"""Linearisation and stability analysis of the closed loop (issue 5).

The analysis diagram is the flight diagram without SceneGraph: the same
plant (`diagram.make_plant`), navigator, selector, attitude PD and mixer,
wired by `diagram.connect_controller`, with the navigator's "obstacle" input
fed by a constant "nothing seen" source. Its selector has a fixed mode
(eq 21's PD or cruise), so the diagram has no discrete state and Drake's
`Linearize` converts it to AutoDiffXd as it is.

What is computed (see `run_analysis`):
- the plant at hover: A, B and its controllability (eq 7 linearised);
- the closed loop at hover at the goal in PD mode (eq 20–25): eigenvalues,
  damping, Drake's `Linearize` against central finite differences;
- a root-locus sweep of K_P, K_D (eq 20) and K_Pθ, K_Dθ (eq 25);
- along a simulated flight: the power of the zero-work terms F, F_a, F_gc
  (eq 12, 14, 18) at field level and as the vehicle realises them, the
  cruise speed (eq 19) and the heading decay of eq 17;
- the region of attraction of the PD mode: an SOS certificate on a reduced
  polynomial model, and sampled starts of the full vehicle.
"""

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from pydrake.examples import QuadrotorPlant
from pydrake.solvers import ScsSolver
from pydrake.symbolic import Evaluate, Jacobian, Variable
from pydrake.systems.analysis import (
    RegionOfAttraction,
    RegionOfAttractionOptions,
    Simulator,
)
from pydrake.systems.framework import Diagram, DiagramBuilder, EventStatus
from pydrake.systems.primitives import (
    ConstantVectorSource,
    Linearize,
    LinearSystem,
    LogVectorOutput,
    SymbolicVectorSystem,
    TrajectorySource,
)
from pydrake.trajectories import PiecewisePolynomial

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicles import VEHICLES, Vehicle
from mfi_drake.flight.diagram import connect_controller, make_plant
from mfi_drake.flight.simulation import Flight, simulate
from mfi_drake.maths import fields
from mfi_drake.maths.layout import OBSTACLE_SIGNAL_SIZE
from mfi_drake.maths.quadcopter import GRAVITY, attitude_gains
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.navigation import GoalAttractionSelector, MfiNavigator

STATE_NAMES = ["x", "y", "z", "roll", "pitch", "yaw"] + [
    f"d{n}" for n in ("x", "y", "z", "roll", "pitch", "yaw")
]
# The gains of the root-locus sweep: eq 20's K_P, K_D and eq 25's K_Pθ, K_Dθ.
SWEPT_GAINS = ("K_P", "K_D", "K_Ptheta", "K_Dtheta")


# --- the analysis diagram ---------------------------------------------------
@dataclass
class AnalysisDiagram:
    diagram: Diagram
    plant: QuadrotorPlant
    vehicle: Vehicle
    params: NavigatorParams
    goal: np.ndarray


def build_analysis_diagram(
    scenario: Scenario,
    mode: int = fields.MODE_PD,
    attitude_K: tuple[np.ndarray, np.ndarray] | None = None,
) -> AnalysisDiagram:
    """The MFI closed loop of `scenario` with eq 21's `mode` fixed and no
    obstacle seen; `attitude_K` = (K_Pθ, K_Dθ) overrides eq 25's gains."""
    vehicle = VEHICLES[scenario.vehicle]
    params = scenario.navigator
    goal = np.asarray(scenario.goal, float)
    K_P, K_D = attitude_K if attitude_K is not None else (None, None)
    builder = DiagramBuilder()
    plant = builder.AddNamedSystem("quadrotor", make_plant(vehicle))
    nothing_seen = builder.AddNamedSystem(
        "no_obstacle", ConstantVectorSource(np.zeros(OBSTACLE_SIGNAL_SIZE))
    )
    controller = [
        builder.AddNamedSystem(name, system)
        for name, system in (
            ("navigator", MfiNavigator(params, goal, vehicle.collision_radius)),
            ("selector", GoalAttractionSelector(params, goal, mode)),
            ("attitude_pd", AttitudePD(vehicle, params, K_P, K_D)),
            ("mixer", RotorMixer(vehicle)),
        )
    ]
    connect_controller(builder, plant, nothing_seen.get_output_port(0), *controller)
    diagram = builder.Build()
    diagram.set_name(f"mfi_drake analysis[{scenario.name}, mode {mode}]")
    return AnalysisDiagram(diagram, plant, vehicle, params, goal)


def hover_state(position) -> np.ndarray:
    """At rest and level at `position`."""
    x = np.zeros(12)
    x[0:3] = position
    return x


def time_derivatives(diagram: Diagram, x: np.ndarray) -> np.ndarray:
    context = diagram.CreateDefaultContext()
    context.SetContinuousState(x)
    return diagram.EvalTimeDerivatives(context).CopyToVector()


def linearize_closed_loop(analysis: AnalysisDiagram, x0: np.ndarray) -> np.ndarray:
    """A of the closed loop at x0 by Drake's `Linearize` (AutoDiffXd)."""
    context = analysis.diagram.CreateDefaultContext()
    context.SetContinuousState(x0)
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
def modes(eigenvalues: np.ndarray) -> dict:
    """Damping ratios and time constants of a set of stable eigenvalues."""
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
    vehicle = VEHICLES[scenario.vehicle]
    K_Ptheta, K_Dtheta = attitude_gains(vehicle, params)
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
    K_Ptheta, K_Dtheta = attitude_gains(VEHICLES[scenario.vehicle], scenario.navigator)
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


# --- cruise mode along a flight -----------------------------------------------
def heading_error(v: np.ndarray, r_g: np.ndarray) -> np.ndarray:
    """β, the angle between the velocity and the goal direction [rad], per row
    (NaN where either is zero)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.sum(v * r_g, axis=1) / (
            np.linalg.norm(v, axis=1) * np.linalg.norm(r_g, axis=1)
        )
    return np.arccos(np.clip(cos, -1.0, 1.0))


def realised_force(flight: Flight, vehicle: Vehicle) -> np.ndarray:
    """The force the vehicle actually applies besides gravity, T R e_z − m g e_z,
    from the logged attitude and rotor commands (R = Rz Ry Rx, Drake's)."""
    x = flight.log["state"]
    roll, pitch, yaw = x[:, 3], x[:, 4], x[:, 5]
    thrust = vehicle.kF * flight.log["propeller_force"].sum(axis=1)
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    z_axis = np.column_stack([cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr])
    return thrust[:, None] * z_axis - np.array([0.0, 0.0, vehicle.weight])


def attitude_response(
    times: np.ndarray,
    forces: np.ndarray,
    initial: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
) -> np.ndarray:
    """Each column of `forces` passed through a/(s² + b s + a), the attitude
    loop's closed-loop response (eq 25 with the plant's J), by Drake, from
    `initial` at rest.

    The vehicle realises a horizontal force by tilting, and its tilt follows
    the commanded tilt (eq 24) through this response, so this is the force
    the vehicle realises for a commanded force signal (linear, small tilt).
    """
    knots, first = np.unique(times, return_index=True)
    k = forces.shape[1]
    A = np.zeros((2 * k, 2 * k))
    B = np.zeros((2 * k, k))
    C = np.zeros((k, 2 * k))
    for i in range(k):
        A[2 * i, 2 * i + 1] = 1.0
        A[2 * i + 1, 2 * i] = -a[i]
        A[2 * i + 1, 2 * i + 1] = -b[i]
        B[2 * i + 1, i] = a[i]
        C[i, 2 * i] = 1.0
    builder = DiagramBuilder()
    source = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.FirstOrderHold(knots, forces[first].T))
    )
    response = builder.AddSystem(LinearSystem(A, B, C, np.zeros((k, k))))
    builder.Connect(source.get_output_port(0), response.get_input_port(0))
    logger = LogVectorOutput(response.get_output_port(0), builder, 0.0)
    simulator = Simulator(builder.Build())
    integrator = simulator.get_mutable_integrator()
    integrator.set_maximum_step_size(0.005)
    integrator.set_target_accuracy(1e-8)
    context = simulator.get_mutable_context()
    x0 = np.zeros(2 * k)
    x0[0::2] = initial  # the realised force at times[0], at rest
    response.GetMyMutableContextFromRoot(context).SetContinuousState(x0)
    simulator.AdvanceTo(knots[-1])
    log = logger.FindLog(context)
    t_log, at = np.unique(log.sample_times(), return_index=True)
    return np.column_stack([np.interp(times, t_log, row[at]) for row in log.data()])


ZERO_WORK_TERMS = ("F", "F_a", "F_gc")  # eq 12, 14, 18: each ⟂ v


def logged_terms(flight: Flight) -> dict[str, np.ndarray]:
    obstacle, goal = flight.log["obstacle_force_terms"], flight.log["goal_force_terms"]
    return {
        "F": obstacle[:, 0:3],
        "F_a": obstacle[:, 3:6],
        "F_gc": goal[:, 0:3],
        "F_v": goal[:, 3:6],
        "F_pd": goal[:, 6:9],
    }


def recomputed_zero_work_terms(flight: Flight, vehicle: Vehicle) -> dict:
    """F, F_a (eq 11–15) and F_gc (eq 16–18) recomputed by `fields` at every
    logged state from the logged obstacle signal and mode."""
    scenario, params = flight.scenario, flight.scenario.navigator
    goal = np.asarray(scenario.goal, float)
    x, obstacle = flight.log["state"], flight.log["obstacle"]
    cruise = flight.log["mode"][:, 0] == fields.MODE_CRUISE
    F, F_a, F_gc = (np.zeros((len(x), 3)) for _ in range(3))
    for i in range(len(x)):
        p, v = x[i, 0:3], x[i, 6:9]
        F[i], F_a[i] = fields.superposed(
            fields.obstacle_field,
            v,
            obstacle[i],
            goal - p,
            vehicle.collision_radius,
            params,
        )
        if cruise[i]:
            F_gc[i] = fields.goal_attraction_field(v, goal - p, params.K_omega)
    return {"F": F, "F_a": F_a, "F_gc": F_gc}


def cruise_report(flight: Flight, attitude_K=None) -> dict:
    """Power of the zero-work terms, cruise speed and heading along `flight`.

    Field level: P = term·v with each term recomputed by `fields` at the
    logged states. Realised: the vehicle applies a term only through its
    tilt, which lags; the realised term is the logged term passed through
    `attitude_response` (vertical parts are realised at once: the thrust has
    no lag in the plant), and its power is that times v. The sum of the
    realised terms is checked against the force the vehicle actually
    applied (`realised_force`); (applied − F_n)·v is the model-free lag power.
    """
    scenario, params = flight.scenario, flight.scenario.navigator
    vehicle = VEHICLES[scenario.vehicle]
    t, x = flight.times, flight.log["state"]
    v = x[:, 6:9]
    goal = np.asarray(scenario.goal, float)
    terms = logged_terms(flight)
    recomputed = recomputed_zero_work_terms(flight, vehicle)
    field_power = {k: np.sum(recomputed[k] * v, axis=1) for k in ZERO_WORK_TERMS}
    log_mismatch = max(
        float(np.abs(recomputed[k] - terms[k]).max()) for k in ZERO_WORK_TERMS
    )

    K_Ptheta, K_Dtheta = attitude_K or attitude_gains(vehicle, params)
    J = np.asarray(vehicle.inertia)
    # x is realised by pitch (axis 1), y by roll (axis 0).
    a = np.array([K_Ptheta[1] / J[1], K_Ptheta[0] / J[0]])
    b = np.array([K_Dtheta[1] / J[1], K_Dtheta[0] / J[0]])
    names = list(terms)
    horizontal = np.hstack([terms[k][:, 0:2] for k in names])
    applied = realised_force(flight, vehicle)
    filtered = attitude_response(
        t,
        horizontal,
        np.zeros(horizontal.shape[1]),  # flights start level: no tilt force
        np.tile(a, len(names)),
        np.tile(b, len(names)),
    )
    realised_terms = {
        k: np.column_stack([filtered[:, 2 * i : 2 * i + 2], terms[k][:, 2]])
        for i, k in enumerate(names)
    }
    model_sum = sum(realised_terms.values())
    residual = np.linalg.norm(model_sum - applied, axis=1)
    realised_power = {k: np.sum(realised_terms[k] * v, axis=1) for k in names}
    lag_power = np.sum((applied - flight.log["navigation_force"]) * v, axis=1)

    speed = np.linalg.norm(v, axis=1)
    cruise = flight.log["mode"][:, 0] == fields.MODE_CRUISE
    r_g = goal - x[:, 0:3]
    beta = heading_error(v, r_g)
    report = {
        "zero_work_field_max_abs_power": max(
            float(np.abs(p).max()) for p in field_power.values()
        ),
        "field_power_max_abs": {
            k: float(np.abs(p).max()) for k, p in field_power.items()
        },
        "recomputed_vs_logged_max_difference": log_mismatch,
        "realised_power_max_abs": {
            k: float(np.abs(realised_power[k]).max()) for k in ZERO_WORK_TERMS
        },
        "realised_work": {
            k: float(np.trapezoid(realised_power[k], t)) for k in ZERO_WORK_TERMS
        },
        "lag_power_max_abs": float(np.abs(lag_power).max()),
        "lag_work": float(np.trapezoid(lag_power, t)),
        "realised_model_residual_rms": float(np.sqrt(np.mean(residual**2))),
        "realised_force_rms": float(np.sqrt(np.mean(np.sum(applied**2, axis=1)))),
        "speed": speed_report(t, speed, cruise, params.v_d),
        "heading": heading_window_report(flight, beta, cruise, vehicle),
    }
    series = {
        "t": t,
        "field_power": field_power,
        "realised_power": {k: realised_power[k] for k in ZERO_WORK_TERMS},
        "lag_power": lag_power,
        "speed": speed,
        "cruise": cruise,
        "beta": beta,
    }
    return {"report": report, "series": series}


def speed_report(t: np.ndarray, speed: np.ndarray, cruise: np.ndarray, v_d: float):
    """Speed while cruising; "settled" counts from the first time the speed
    reaches 0.9 v_d after the switch to cruise (eq 19's transient excluded)."""
    if not cruise.any():
        return {"cruise_time": 0.0}
    settled = cruise & (np.cumsum(cruise & (speed >= 0.9 * v_d)) > 0)
    dt = np.diff(t, append=t[-1])
    within = settled & (np.abs(speed - v_d) <= 0.1 * v_d)
    return {
        "v_d": v_d,
        "cruise_time": float(dt[cruise].sum()),
        "settled_mean": float(np.average(speed[settled], weights=dt[settled] + 1e-12)),
        "settled_min": float(speed[settled].min()),
        "settled_max": float(speed[settled].max()),
        "fraction_within_10_percent": float(dt[within].sum() / dt[settled].sum()),
    }


def point_mass_heading(
    p0: np.ndarray,
    v0: np.ndarray,
    goal: np.ndarray,
    params: NavigatorParams,
    mass: float,
    times: np.ndarray,
) -> np.ndarray:
    """β(t) of a point mass m v̇ = F_gc + F_v (eq 16–19, the fields' own
    functions) from (p0, v0), by RK4 at ≤ 1 ms steps, sampled at `times`."""

    def derivative(s):
        p, v = s[0:3], s[3:6]
        force = fields.goal_attraction_field(v, goal - p, params.K_omega)
        force = force + fields.speed_control_field(v, params.K_v, params.v_d)
        return np.concatenate([v, force / mass])

    s = np.concatenate([p0, v0])
    out = [s]
    for t0, t1 in zip(times[:-1], times[1:], strict=True):
        n = max(1, int(np.ceil((t1 - t0) / 1e-3)))
        h = (t1 - t0) / n
        for _ in range(n):
            k1 = derivative(s)
            k2 = derivative(s + 0.5 * h * k1)
            k3 = derivative(s + 0.5 * h * k2)
            k4 = derivative(s + h * k3)
            s = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(s)
    out = np.array(out)
    return heading_error(out[:, 3:6], goal - out[:, 0:3])


def decay_rate(t: np.ndarray, beta: np.ndarray, floor: float = 0.02) -> float:
    """Least-squares rate λ of β ≈ β0 e^(−λ t) over the samples with β > floor."""
    keep = beta > floor
    slope = np.polyfit(t[keep], np.log(beta[keep]), 1)[0]
    return float(-slope)


def heading_window_report(
    flight: Flight, beta: np.ndarray, cruise: np.ndarray, vehicle: Vehicle
) -> dict:
    """Eq 17 in a stretch of cruise with no obstacle field (F = F_a = 0):
    the measured β against the point-mass closed form
    β0 exp(−K_ω t / m) (far goal) and the point mass flown from the same
    state toward the real goal."""
    params = flight.scenario.navigator
    obstacle_free = np.all(flight.log["obstacle_force_terms"] == 0.0, axis=1)
    edges = np.diff(np.concatenate([[0], (cruise & obstacle_free).astype(int), [0]]))
    runs = list(zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0], strict=True))
    # The run that starts with the largest heading error (at least 0.05 rad
    # and 0.3 s long): typically the one just after the obstacle.
    runs = [
        r
        for r in runs
        if beta[r[0]] > 0.05 and flight.times[r[1] - 1] - flight.times[r[0]] > 0.3
    ]
    if not runs:
        return {"window": None}
    best = max(runs, key=lambda r: beta[r[0]])
    window = slice(*best)
    t = flight.times[window] - flight.times[best[0]]
    x0 = flight.log["state"][best[0]]
    goal = np.asarray(flight.scenario.goal, float)
    rate = params.K_omega / vehicle.mass
    point_mass = point_mass_heading(x0[0:3], x0[6:9], goal, params, vehicle.mass, t)
    measured = beta[window]
    return {
        "window": [float(flight.times[best[0]]), float(flight.times[best[1] - 1])],
        "beta_start": float(measured[0]),
        "beta_end": float(measured[-1]),
        "closed_form_rate": rate,
        "measured_rate": decay_rate(t, measured),
        "point_mass_rate": decay_rate(t, point_mass),
        "max_difference_to_point_mass": float(np.abs(measured - point_mass).max()),
        "series": {"t": t, "measured": measured, "point_mass": point_mass},
    }


def far_goal_heading(scenario: Scenario, duration: float = 3.0) -> dict:
    """Eq 17 where its closed form is exact for a point mass: cruise mode, no
    obstacle, the goal 1 km ahead along x, the vehicle flying at v_d along y
    (β0 = π/2): vehicle β(t) against β0 exp(−K_ω t / m).

    The vehicle realises F_gc through its tilt, i.e. through a/(s² + b s + a)
    (`attitude_response`); with that lag the linearised heading loop is
    s³ + b s² + a s + a K_Pv K_ω/m = 0, whose slowest root is the
    "lagged_model_rate" to compare with the vehicle's asymptotic rate."""
    params = scenario.navigator
    start = np.asarray(scenario.start, float)
    far = dataclasses.replace(scenario, goal=list(start + [1000.0, 0.0, 0.0]))
    analysis = build_analysis_diagram(far, fields.MODE_CRUISE)
    simulator = Simulator(analysis.diagram)
    context = simulator.get_mutable_context()
    x0 = hover_state(start)
    x0[7] = params.v_d
    context.SetContinuousState(x0)
    times = np.linspace(0.0, duration, 301)
    states = []
    for t in times:
        simulator.AdvanceTo(t)
        states.append(context.get_continuous_state_vector().CopyToVector())
    states = np.array(states)
    beta = heading_error(states[:, 6:9], analysis.goal - states[:, 0:3])
    rate = params.K_omega / analysis.vehicle.mass
    closed_form = beta[0] * np.exp(-rate * times)
    point_mass = point_mass_heading(
        x0[0:3], x0[6:9], analysis.goal, params, analysis.vehicle.mass, times
    )
    e_fold = float(np.interp(-1.0 / np.e, -beta / beta[0], times))
    c = reduced_model_constants(scenario)
    lagged = np.roots([1.0, c["b"], c["a"], c["a"] * c["K_Pv"] * rate])
    tail = times >= 1.0
    return {
        "closed_form_rate": rate,
        "closed_form_time_constant": 1.0 / rate,
        "lagged_model_rate": float(-lagged.real.max()),
        "vehicle_e_fold_time": e_fold,
        "vehicle_rate": decay_rate(times[tail], beta[tail], floor=1e-4),
        "point_mass_max_difference_to_closed_form": float(
            np.abs(point_mass - closed_form).max()
        ),
        "vehicle_max_difference_to_closed_form": float(
            np.abs(beta - closed_form).max()
        ),
        "series": {"t": times, "vehicle": beta, "closed_form": closed_form},
    }


# --- region of attraction of the PD mode ---------------------------------------
def reduced_terminal_dynamics(x, m, K_P, K_D, K_Pv, a, b) -> list:
    """The reduced polynomial model of one horizontal axis in PD mode.

    State (e, v, θ, ω): position error p − p_g [m], velocity [m/s], the tilt
    that drives this axis (pitch for x) [rad] and its rate [rad/s]; the other
    axes, altitude and yaw at rest. With the tilt compensation of eq 21 (after)
    the thrust is m g / cos θ, so v̇ = g tan θ, and eq 24 asks for
    θ_d = K_Pv F cos θ / (m g) with F = −K_P e − K_D v (eq 20, unsaturated);
    eq 25 with a = K_Pθ/J, b = K_Dθ/J gives ω̇ = −a (θ − θ_d) − b ω.
    tan and cos are replaced by their Taylor polynomials to third order
    (error < 1 % for |θ| ≤ 0.5 rad). Works on floats, numpy arrays and
    symbolic Variables alike.
    """
    e, v, theta, omega = x
    force = -K_P * e - K_D * v
    theta_d = K_Pv * (1.0 - theta**2 / 2.0) * force / (m * GRAVITY)
    return [
        v,
        GRAVITY * (theta + theta**3 / 3.0),
        omega,
        -a * (theta - theta_d) - b * omega,
    ]


def reduced_model_constants(scenario: Scenario) -> dict:
    vehicle = VEHICLES[scenario.vehicle]
    params = scenario.navigator
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
    params = scenario.navigator
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
            "(analysis.reduced_terminal_dynamics)"
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

    def converged(radius: np.ndarray) -> np.ndarray:
        zero = np.zeros_like(radius)
        x = np.array([radius * np.cos(angles), radius * np.sin(angles), zero, zero])
        with np.errstate(all="ignore"):
            for _ in range(int(horizon / h)):
                k1 = np.array(reduced_terminal_dynamics(x, **constants))
                k2 = np.array(reduced_terminal_dynamics(x + 0.5 * h * k1, **constants))
                k3 = np.array(reduced_terminal_dynamics(x + 0.5 * h * k2, **constants))
                k4 = np.array(reduced_terminal_dynamics(x + h * k3, **constants))
                x = np.clip(x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), -1e6, 1e6)
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
    context.SetContinuousState(x0)
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


# --- everything --------------------------------------------------------------
def run_analysis(
    scenario: Scenario,
    out_dir: str,
    roa_radii: tuple[float, ...] = (0.5, 2.0, 8.0, 32.0),
) -> dict:
    """Runs every analysis of this module on `scenario`, writes the figures
    under `out_dir` and returns the JSON-ready report."""
    from mfi_drake.app.analysis_figures import (  # TODO(split): figures in app
        plot_eigenvalues,
        plot_heading,
        plot_power,
        plot_roa,
    )

    begin = time.perf_counter()
    vehicle = VEHICLES[scenario.vehicle]
    report = {"scenario": scenario.name, "vehicle": vehicle.name}

    plant = plant_report(vehicle)
    report["plant"] = plant
    report["controllability_rank"] = plant["controllability_rank"]

    analysis = build_analysis_diagram(scenario, fields.MODE_PD)
    x0 = hover_state(analysis.goal)
    A = linearize_closed_loop(analysis, x0)
    A_fd = finite_difference_jacobian(analysis.diagram, x0)
    eigenvalues = np.linalg.eigvals(A)
    eigenvalues = eigenvalues[np.lexsort((eigenvalues.imag, eigenvalues.real))]
    report.update(modes(eigenvalues))
    report["linearize_vs_fd_max_error"] = float(np.abs(A - A_fd).max())
    report["hover_equilibrium_residual"] = float(
        np.abs(time_derivatives(analysis.diagram, x0)).max()
    )

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
    sampled = roa_sampled(scenario, radii, roa_directions())
    report["roa_sampled"] = {k: v for k, v in sampled.items() if k != "outcomes"}
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

    figures = {
        "eigenvalues": f"{out_dir}/eigenvalues.png",
        "power": f"{out_dir}/power.png",
        "heading": f"{out_dir}/heading.png",
        "roa": f"{out_dir}/roa.png",
    }
    plot_eigenvalues(eigenvalues, sweep, figures["eigenvalues"])
    plot_power(cruise["series"], scenario.navigator.v_d, figures["power"])
    plot_heading(window_series, far_series, far["closed_form_rate"], figures["heading"])
    plot_roa(
        sos,
        (angles, boundary),
        sampled,
        radii,
        roa_directions(),
        figures["roa"],
    )
    report["figures"] = figures
    report["wall_time"] = time.perf_counter() - begin
    return report


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
            f"cruise speed (settled): {cruise['speed']['settled_min']:.2f}–"
            f"{cruise['speed']['settled_max']:.2f} m/s for v_d = "
            f"{cruise['speed']['v_d']} m/s",
            f"heading decay (far goal): vehicle e-fold "
            f"{report['far_goal_heading']['vehicle_e_fold_time']:.3g} s vs m/K_ω = "
            f"{report['far_goal_heading']['closed_form_time_constant']:.3g} s",
            f"ROA (PD mode): SOS on the reduced model {sos['radius']:.3g}; sampled "
            f"full vehicle {'≥ ' if sampled['lower_bound_only'] else ''}"
            f"{sampled['radius']:.3g} (|(Δp [m], Δv [m/s])|)",
        ]
    )
