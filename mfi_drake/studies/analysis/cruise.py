"""Cruise mode along a simulated flight: the power of the zero-work terms F,
F_a, F_gc (eq 12, 14, 18) at field level and as the vehicle realises them,
the cruise speed (eq 19) and the heading decay of eq 17."""

import dataclasses

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LinearSystem, LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.flight.analysis_diagram import build_analysis_diagram, hover_state
from mfi_drake.flight.result import Flight
from mfi_drake.maths import fields
from mfi_drake.maths.quadcopter import attitude_gains
from mfi_drake.maths.reduced_models import heading_error, point_mass_heading
from mfi_drake.studies.analysis.roa import reduced_model_constants


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


def flown_params(flight: Flight):
    """The navigator parameters `flight`'s vehicle flew: the scenario's, for
    its vehicle (`config.vehicle_gains`)."""
    scenario = flight.scenario
    return for_vehicle(scenario.navigator, as_vehicle(scenario.vehicle))


def recomputed_zero_work_terms(flight: Flight, vehicle: Vehicle) -> dict:
    """F, F_a (eq 11–15) and F_gc (eq 16–18) recomputed by `fields` at every
    logged state from the logged obstacle signal and mode."""
    scenario, params = flight.scenario, flown_params(flight)
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


def _realised_terms(flight: Flight, terms: dict, vehicle, params, attitude_K) -> dict:
    """Each of the logged `terms` as the vehicle realises it: its horizontal
    part through `attitude_response` with the attitude gains `attitude_K`
    (default: the flight's), its vertical part at once."""
    K_Ptheta, K_Dtheta = attitude_K or attitude_gains(vehicle, params)
    J = np.asarray(vehicle.inertia)
    # x is realised by pitch (axis 1), y by roll (axis 0).
    a = np.array([K_Ptheta[1] / J[1], K_Ptheta[0] / J[0]])
    b = np.array([K_Dtheta[1] / J[1], K_Dtheta[0] / J[0]])
    names = list(terms)
    horizontal = np.hstack([terms[k][:, 0:2] for k in names])
    filtered = attitude_response(
        flight.times,
        horizontal,
        np.zeros(horizontal.shape[1]),  # flights start level: no tilt force
        np.tile(a, len(names)),
        np.tile(b, len(names)),
    )
    return {
        k: np.column_stack([filtered[:, 2 * i : 2 * i + 2], terms[k][:, 2]])
        for i, k in enumerate(names)
    }


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
    scenario, params = flight.scenario, flown_params(flight)
    vehicle = as_vehicle(scenario.vehicle)
    t, x = flight.times, flight.log["state"]
    v = x[:, 6:9]
    goal = np.asarray(scenario.goal, float)
    terms = logged_terms(flight)
    recomputed = recomputed_zero_work_terms(flight, vehicle)
    field_power = {k: np.sum(recomputed[k] * v, axis=1) for k in ZERO_WORK_TERMS}
    log_mismatch = max(
        float(np.abs(recomputed[k] - terms[k]).max()) for k in ZERO_WORK_TERMS
    )

    realised_terms = _realised_terms(flight, terms, vehicle, params, attitude_K)
    applied = realised_force(flight, vehicle)
    model_sum = sum(realised_terms.values())
    residual = np.linalg.norm(model_sum - applied, axis=1)
    realised_power = {k: np.sum(r * v, axis=1) for k, r in realised_terms.items()}
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
    cruise_time = float(dt[cruise].sum())
    if dt[settled].sum() <= 0.0:  # a short flight: never settled in cruise
        return {"v_d": v_d, "cruise_time": cruise_time}
    within = settled & (np.abs(speed - v_d) <= 0.1 * v_d)
    return {
        "v_d": v_d,
        "cruise_time": cruise_time,
        "settled_mean": float(np.average(speed[settled], weights=dt[settled] + 1e-12)),
        "settled_min": float(speed[settled].min()),
        "settled_max": float(speed[settled].max()),
        "fraction_within_10_percent": float(dt[within].sum() / dt[settled].sum()),
    }


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
    params = flown_params(flight)
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
    start = np.asarray(scenario.start, float)
    far = dataclasses.replace(scenario, goal=list(start + [1000.0, 0.0, 0.0]))
    analysis = build_analysis_diagram(far, fields.MODE_CRUISE)
    params = analysis.params  # the vehicle's (`config.vehicle_gains`)
    simulator = Simulator(analysis.diagram)
    context = simulator.get_mutable_context()
    x0 = hover_state(start)
    x0[7] = params.v_d
    context.SetContinuousState(analysis.state(x0))
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
