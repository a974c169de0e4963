"""From the navigation force F_n to rotor commands (the paper's §V).

Plain numpy on float or AutoDiffXd arrays, like `fields`. Drake's
QuadrotorPlant conventions (see `layout`): state (x, y, z, roll, pitch, yaw,
ẋ, ẏ, ż, roll̇, pitcḣ, yaẇ), R = Rz(yaw) Ry(pitch) Rx(roll); +pitch tilts the
thrust toward +x, +roll toward −y.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from mfi_drake.maths.constants import GRAVITY
from mfi_drake.maths.layout import ANGULAR_RATE, ATTITUDE, ROTORS, VELOCITY
from mfi_drake.maths.so3 import cos, entries, floor, sin, sqrt

if TYPE_CHECKING:  # annotations only: the maths layer needs no configuration
    from mfi_drake.config.parameters import NavigatorParams
    from mfi_drake.config.vehicles import Vehicle


def attitude_gains(
    vehicle: Vehicle, params: NavigatorParams
) -> tuple[np.ndarray, np.ndarray]:
    """K_Pθ and K_Dθ of eq 25 per axis (roll, pitch, yaw) [N·m/rad, N·m·s/rad].

    Chosen as J ω_n² and 2 ζ ω_n J so that each axis is a second-order loop
    with the natural frequency and damping of `params`, whatever the inertia.
    """
    J = np.asarray(vehicle.inertia)
    w = params.attitude_natural_frequency
    return J * w * w, 2.0 * params.attitude_damping_ratio * w * J


def _thrust_floor(weight, level, params: NavigatorParams):
    """The least vertical force F_z + m g the rotors deliver, T_min ℓ."""
    return params.min_thrust_fraction * weight * level


def _delivered_scale(F_x, F_y, F_z, level, weight, params: NavigatorParams):
    """The largest k ∈ (0, 1] for which k F is deliverable: T(k) = (k F_z +
    m g)/ℓ ≥ T_min gives k ≤ (m g − T_min ℓ)/(−F_z), and K_Pv k |F_h| /
    T(k) ≤ max_tilt gives k ≤ max_tilt m g / (K_Pv |F_h| ℓ − max_tilt F_z)."""
    k = 1.0
    T_min = _thrust_floor(weight, level, params)
    if F_z + weight < T_min:
        k = (weight - T_min) / (-F_z)
    f_h = params.K_Pv * sqrt(F_x * F_x + F_y * F_y)
    if f_h * level * k > params.max_tilt * (k * F_z + weight):
        k = params.max_tilt * weight / (f_h * level - params.max_tilt * F_z)
    return k


def _brake_first(F, v, level, weight, params: NavigatorParams) -> tuple:
    """F_n = b + q, b its part along −v (braking), delivered as s b + k q:
    s ∈ (0, 1] scales b into the limits shrunk by `brake_margin` δ (s = 1
    when (1 − δ)⁻¹ b fits), then k ∈ [0, 1] is the largest that keeps
    s b + k q deliverable. Where b alone does not fit, q is still added: a
    q that lifts makes room for tilt, so dropping it would make the
    delivered force jump as b crosses the limit (an integrator then
    chatters on that surface: tree_on_ground took 2000 steps of 10 µs
    there). δ keeps s b inside the convex set of deliverable forces, where
    the exit k along q is continuous in q and s b; from a point on its
    boundary k jumps between 1 and 0 as q turns across the tangent plane."""
    F_x, F_y, F_z = F
    speed_sq = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    along = (F_x * v[0] + F_y * v[1] + F_z * v[2]) / speed_sq if speed_sq > 0 else 0
    if along >= 0.0:  # nothing brakes: one scale for all of F_n
        k = _delivered_scale(F_x, F_y, F_z, level, weight, params)
        return k * F_x, k * F_y, k * F_z
    q = (F_x - along * v[0], F_y - along * v[1], F_z - along * v[2])
    # The scale of b/(1 − δ) is min(1, (1 − δ) s_max(b)): the scale is 1/gauge.
    u = along / (1.0 - params.brake_margin)
    along = along * _delivered_scale(
        u * v[0], u * v[1], u * v[2], level, weight, params
    )
    b = (along * v[0], along * v[1], along * v[2])
    k = 1.0
    T_min = _thrust_floor(weight, level, params)
    if q[2] < 0.0 and b[2] + q[2] + weight < T_min:  # T is linear in k
        k = (b[2] + weight - T_min) / (-q[2])
    # K_Pv² ℓ² |b_h + k q_h|² ≤ max_tilt² (b_z + k q_z + m g)²: a k² + 2β k + γ
    # ≤ 0 with γ ≤ 0 (b is deliverable); its crossing to > 0 is the root
    # (−β + √(β² − aγ))/a = −γ/(β + √(β² − aγ)), each form used where it
    # does not cancel (β < 0 with a crossing in (0, 1] needs a > 0).
    K = params.K_Pv * level
    K2 = K * K
    t2 = params.max_tilt * params.max_tilt
    lift = b[2] + weight
    a = K2 * (q[0] * q[0] + q[1] * q[1]) - t2 * q[2] * q[2]
    beta = K2 * (b[0] * q[0] + b[1] * q[1]) - t2 * q[2] * lift
    gamma = K2 * (b[0] * b[0] + b[1] * b[1]) - t2 * lift * lift
    if a * k * k + 2.0 * beta * k + gamma > 0.0:
        discriminant = beta * beta - a * gamma
        root = sqrt(discriminant) if discriminant > 0.0 else 0.0 * discriminant
        if beta >= 0.0:
            k = -gamma / (beta + root) if beta + root > 0.0 else 0.0 * root
        elif a > 0.0:  # else only a rounding of γ above 0 got here: keep k
            k = (root - beta) / a
    if k < 0.0:  # a rounding: b is on a limit
        k = 0.0 * k
    return b[0] + k * q[0], b[1] + k * q[1], b[2] + k * q[2]


def attitude_setpoint(
    F_n: np.ndarray,
    attitude: np.ndarray,
    yaw_desired,
    vehicle: Vehicle,
    params: NavigatorParams,
    v: np.ndarray | None = None,
) -> np.ndarray:
    """Eq 21 (after) – 24: [T, roll_d, pitch_d, yaw_d] from F_n.

    F_Q = F_n + m g e_z, T = F_Q·e_z (divided by ℓ = cos roll · cos pitch
    when `tilt_compensation`, so the vertical force is F_Qz at any tilt; ℓ
    is held at cos max_tilt beyond the tilt limit). The planar force
    f = K_Pv [F_nx, F_ny] (eq 22) is expressed in the yaw frame and turned
    into small-angle tilts (eq 23–24) with Drake's signs: pitch_d = f_x'/T,
    roll_d = −f_y'/T.

    The vehicle can deliver only thrusts T ≥ min_thrust_fraction·m·g and
    tilts |f|/T ≤ max_tilt. When F_n asks for more, all of F_n is scaled
    by the largest k ∈ (0, 1] it can deliver (`_delivered_scale`). Limiting
    the tilt or the thrust alone would deliver one part of F_n in full and
    the other in part: the delivered force would turn away from F_n
    (towards free fall when F_n pulls down), and the terms of F_n that do
    no work (⟂ v, eq 11–15) would start doing work. Scaling keeps F_n's
    direction. With `params.brake_first` and the velocity `v`, F_n's part
    along −v is delivered first and the rest scaled into what remains
    (`_brake_first`): the terms ⟂ v still do no work, and the braking that
    a large ⟂ command would otherwise scale away is kept.
    """
    roll, pitch, yaw = entries(attitude)
    F = entries(F_n)
    weight = vehicle.mass * GRAVITY
    level = 1.0
    if params.tilt_compensation:
        level = cos(roll) * cos(pitch)
        if level < cos(params.max_tilt):  # also keeps T > 0 upside down
            level = cos(params.max_tilt) + 0.0 * level
    if params.brake_first and v is not None:
        F_x, F_y, F_z = _brake_first(F, entries(v), level, weight, params)
    else:
        k = _delivered_scale(F[0], F[1], F[2], level, weight, params)
        F_x, F_y, F_z = k * F[0], k * F[1], k * F[2]
    T = (F_z + weight) / level
    f_x = params.K_Pv * F_x
    f_y = params.K_Pv * F_y
    c, s = cos(yaw), sin(yaw)
    pitch_d = (c * f_x + s * f_y) / T
    roll_d = -(-s * f_x + c * f_y) / T
    return np.array([T, roll_d, pitch_d, yaw_desired])


def attitude_command(
    x: np.ndarray,
    F_n: np.ndarray,
    vehicle: Vehicle,
    params: NavigatorParams,
    K_P: np.ndarray,
    K_D: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The attitude PD's outputs at state x for F_n: ([T, τ] (4, eq 25 with
    `attitude_setpoint`'s T), [T, roll_d, pitch_d, yaw_d] (4, eq 21–24))."""
    attitude, rates, v = x[ATTITUDE], x[ANGULAR_RATE], x[VELOCITY]
    yaw_d = desired_yaw(v, attitude[2], params)
    setpoint = attitude_setpoint(F_n, attitude, yaw_d, vehicle, params, v)
    tau = attitude_pd_torque(attitude, rates, setpoint[1:4], K_P, K_D)
    return np.concatenate((setpoint[:1], tau)), setpoint


def wrap_angle(angle):
    """Angle wrapped to [−π, π)."""
    return angle - 2.0 * math.pi * floor((angle + math.pi) / (2.0 * math.pi))


def desired_yaw(v: np.ndarray, yaw, params: NavigatorParams):
    """θ_y,d of eq 25: 0 as in the paper, or with `yaw_follows_motion` the
    direction of horizontal motion atan2(v_y, v_x), blended in from the
    current yaw as the horizontal speed rises from v_stop to v_min (eq 21's
    "v = 0" and "v ≠ 0"), so the setpoint has no jump.
    """
    if not params.yaw_follows_motion:
        return 0.0 * yaw
    speed_sq = v[0] * v[0] + v[1] * v[1]
    if speed_sq <= params.v_stop**2:
        return yaw
    error = wrap_angle(np.arctan2(v[1], v[0]) - yaw)
    if speed_sq >= params.v_min**2:
        return yaw + error
    weight = (np.sqrt(speed_sq) - params.v_stop) / (params.v_min - params.v_stop)
    return yaw + weight * error


def attitude_pd_torque(
    attitude: np.ndarray,
    attitude_rates: np.ndarray,
    desired: np.ndarray,
    K_P: np.ndarray,
    K_D: np.ndarray,
) -> np.ndarray:
    """Eq 25: τ = −K_Pθ (θ − θ_d) − K_Dθ θ̇ for roll, pitch and yaw.

    Drake's plant gives the Euler-angle rates θ̇ directly, so the paper's
    small-angle approximation θ̇ ≈ ω is not needed. The yaw error is wrapped.
    """
    # On Python scalars: cheaper than numpy on 3-vectors.
    roll, pitch, yaw = entries(attitude)
    roll_d, pitch_d, yaw_d = entries(desired)
    P0, P1, P2 = entries(K_P)
    D0, D1, D2 = entries(K_D)
    r0, r1, r2 = entries(attitude_rates)
    return np.array(
        [
            -(P0 * (roll - roll_d) + D0 * r0),
            -(P1 * (pitch - pitch_d) + D1 * r1),
            -(P2 * wrap_angle(yaw - yaw_d) + D2 * r2),
        ]
    )


def rotor_angles(layout: str) -> np.ndarray:
    """Rotor k's direction in the body's xy plane [rad]: "+" (Drake's
    QuadrotorPlant, `layout` module) at 0, 90°, 180°, 270° from +x; "x" at
    45°, 135°, 225°, 315°. Rotors 0 and 2 twist +z, 1 and 3 −z in both."""
    offset = 0.25 * math.pi if layout == "x" else 0.0
    return offset + np.arange(ROTORS) * (0.5 * math.pi)


def rotor_xy(arm_length: float, layout: str = "+") -> np.ndarray:
    """Rotor k's centre (x, y) in the body frame (4 × 2) [m]; the "+"
    layout's entries are exactly ±L and 0."""
    angles = rotor_angles(layout)
    c, s = np.cos(angles), np.sin(angles)
    if layout != "x":
        c, s = np.round(c), np.round(s)
    return arm_length * np.column_stack([c, s]) + 0.0


def mixer_matrix(vehicle: Vehicle) -> np.ndarray:
    """D of eq 8 for the vehicle's rotor layout: [T, τx, τy, τz] = D u, with
    rotor k at (x_k, y_k) pushing kF u_k along +z (τx = kF u y, τy = −kF u x)
    and twisting ±kM u_k about it."""
    kF, kM = vehicle.kF, vehicle.kM
    xy = rotor_xy(vehicle.arm_length, vehicle.layout)
    spin = np.array([1.0, -1.0, 1.0, -1.0])
    return np.vstack(
        [np.full(ROTORS, kF), kF * xy[:, 1], -(kF * xy[:, 0]) + 0.0, kM * spin]
    )


def plus_commands(vehicle: Vehicle) -> np.ndarray:
    """The 4 × 4 map from the vehicle's rotor commands to the commands of
    QuadrotorPlant's "+" rotors that give the body the same thrust and
    torques, D₊⁻¹ D (identity for a "+" vehicle): Drake's plant sums its
    rotors into one wrench, so an "x" vehicle flies exactly through it."""
    plus = dataclasses.replace(vehicle, layout="+")
    return np.linalg.solve(mixer_matrix(plus), mixer_matrix(vehicle))


def mix(thrust_torque: np.ndarray, D_inv, u_max: float):
    """Eq 8 inverted, u = D⁻¹ Γ, kept inside the rotor limits [0, u_max]
    (D_inv: D⁻¹ as an array or as nested lists, which are cheaper to read).

    Plain per-rotor clipping would sacrifice roll/pitch torque, and a
    quadcopter that loses attitude authority tumbles. So the limits are met
    by giving things up in order of importance:
    1. roll/pitch torque is kept; if its spread alone exceeds u_max it is
       scaled down to fit;
    2. the collective thrust is moved into the range the torques leave;
    3. yaw torque gets what room is left (scaled by s ∈ [0, 1]).
    Returns (u, number of rotors left at a limit when anything was given up).
    """
    # Per-rotor lists of Python scalars: cheaper than 4-element arrays.
    T, tau_x, tau_y, tau_z = entries(thrust_torque)
    D = entries(D_inv)
    roll_pitch = [D[i][1] * tau_x + D[i][2] * tau_y for i in range(ROTORS)]
    yaw = [D[i][3] * tau_z for i in range(ROTORS)]
    limited = False
    low, high = min(roll_pitch), max(roll_pitch)
    if high - low > u_max:
        scale = u_max / (high - low)
        for i in range(ROTORS):
            roll_pitch[i] = roll_pitch[i] * scale
        low, high = low * scale, high * scale
        limited = True
    collective = D[0][0] * T  # every rotor carries a quarter of T
    if collective < -low:
        collective, limited = -low + 0.0 * collective, True
    elif collective > u_max - high:
        collective, limited = u_max - high + 0.0 * collective, True
    u = [collective + roll_pitch[i] for i in range(ROTORS)]
    s = 1.0
    for i in range(ROTORS):
        if yaw[i] > 0.0 and u[i] + yaw[i] > u_max:
            s = min(s, (u_max - u[i]) / yaw[i])
        elif yaw[i] < 0.0 and u[i] + yaw[i] < 0.0:
            s = min(s, -u[i] / yaw[i])
    if s < 1.0:
        limited = True
        s = max(s, 0.0)
    forces = np.array([u[i] + s * yaw[i] for i in range(ROTORS)])
    if not limited:
        return forces, 0
    at_limit = 0
    for i in range(ROTORS):
        if forces[i] <= 1e-9 * u_max or forces[i] >= u_max * (1 - 1e-9):
            at_limit += 1
    return forces, max(at_limit, 1)
