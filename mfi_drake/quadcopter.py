"""From the navigation force F_n to rotor commands (the paper's §V).

Plain numpy on float or AutoDiffXd arrays, like `fields`. Drake's
QuadrotorPlant conventions (NOTES.md): state (x, y, z, roll, pitch, yaw,
ẋ, ẏ, ż, roll̇, pitcḣ, yaẇ), R = Rz(yaw) Ry(pitch) Rx(roll); +pitch tilts the
thrust toward +x, +roll toward −y.
"""

import numpy as np

from mfi_drake.parameters import NavigatorParams
from mfi_drake.so3 import cos, entries, sin, sqrt
from mfi_drake.vehicles import GRAVITY, Vehicle


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


def attitude_setpoint(
    F_n: np.ndarray,
    attitude: np.ndarray,
    yaw_desired,
    vehicle: Vehicle,
    params: NavigatorParams,
) -> np.ndarray:
    """Eq 21 (after) – 24: [T, roll_d, pitch_d, yaw_d] from F_n.

    F_Q = F_n + m g e_z, T = F_Q·e_z (divided by cos roll · cos pitch when
    `tilt_compensation`, so the vertical force is F_Qz at any tilt). The
    planar force f = K_Pv [F_nx, F_ny] (eq 22) is expressed in the yaw frame
    and turned into small-angle tilts (eq 23–24) with Drake's signs:
    pitch_d = f_x'/T, roll_d = −f_y'/T. When T is below
    min_thrust_fraction·m·g (F_n pulls down hard, T ≤ 0 included) that floor
    is used in eq 24 so the tilts stay bounded; the tilt vector
    (roll_d, pitch_d) is scaled down to norm max_tilt when longer.
    """
    roll, pitch, yaw = entries(attitude)
    F_x, F_y, F_z = entries(F_n)
    T = F_z + vehicle.mass * GRAVITY
    if params.tilt_compensation:
        T = T / (cos(roll) * cos(pitch))
    T_floor = params.min_thrust_fraction * vehicle.mass * GRAVITY
    T_tilt = T if T_floor < T else T_floor + 0.0 * T
    f_x = params.K_Pv * F_x
    f_y = params.K_Pv * F_y
    c, s = cos(yaw), sin(yaw)
    f_forward = c * f_x + s * f_y
    f_left = -s * f_x + c * f_y
    pitch_d = f_forward / T_tilt
    roll_d = -f_left / T_tilt
    tilt = sqrt(pitch_d * pitch_d + roll_d * roll_d)
    if tilt > params.max_tilt:
        # Scale, not clip per axis: the planar force keeps its direction, so
        # terms ⟂ v stay ⟂ v (zero work) and F_v keeps braking.
        pitch_d = pitch_d * (params.max_tilt / tilt)
        roll_d = roll_d * (params.max_tilt / tilt)
    return np.array([T, roll_d, pitch_d, yaw_desired])


def wrap_angle(angle):
    """Angle wrapped to [−π, π)."""
    return angle - 2.0 * np.pi * np.floor((angle + np.pi) / (2.0 * np.pi))


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
    e_roll, e_pitch, e_yaw = entries(attitude - desired)
    error = np.array([e_roll, e_pitch, wrap_angle(e_yaw)])
    return -(K_P * error + K_D * attitude_rates)


def mixer_matrix(vehicle: Vehicle) -> np.ndarray:
    """D of eq 8 for Drake's rotor layout: [T, τx, τy, τz] = D u."""
    kF, kM, L = vehicle.kF, vehicle.kM, vehicle.arm_length
    return np.array(
        [
            [kF, kF, kF, kF],
            [0.0, L * kF, 0.0, -L * kF],
            [-L * kF, 0.0, L * kF, 0.0],
            [kM, -kM, kM, -kM],
        ]
    )


def mix(thrust_torque: np.ndarray, D_inv: np.ndarray, u_max: float):
    """Eq 8 inverted, u = D⁻¹ Γ, kept inside the rotor limits [0, u_max].

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
    D = D_inv.tolist()
    roll_pitch = [row[1] * tau_x + row[2] * tau_y for row in D]
    yaw = [row[3] * tau_z for row in D]
    limited = False
    low, high = min(roll_pitch), max(roll_pitch)
    if high - low > u_max:
        scale = u_max / (high - low)
        roll_pitch = [x * scale for x in roll_pitch]
        low, high = low * scale, high * scale
        limited = True
    collective = D[0][0] * T  # every rotor carries a quarter of T
    if collective < -low:
        collective, limited = -low + 0.0 * collective, True
    elif collective > u_max - high:
        collective, limited = u_max - high + 0.0 * collective, True
    u = [collective + x for x in roll_pitch]
    s = 1.0
    for u_i, y_i in zip(u, yaw, strict=True):
        if y_i > 0.0 and u_i + y_i > u_max:
            s = min(s, (u_max - u_i) / y_i)
        elif y_i < 0.0 and u_i + y_i < 0.0:
            s = min(s, -u_i / y_i)
    if s < 1.0:
        limited = True
        s = max(s, 0.0)
    u = np.array([u_i + s * y_i for u_i, y_i in zip(u, yaw, strict=True)])
    if not limited:
        return u, 0
    at_limit = sum(1 for u_i in u if u_i <= 1e-9 * u_max or u_i >= u_max * (1 - 1e-9))
    return u, max(at_limit, 1)
