"""Reduced models of the closed loop for `studies.analysis`, plain numpy.

The reduced terminal dynamics of one horizontal axis in PD mode (eq 20–25),
the point-mass heading model of cruise mode (eq 16–19), the heading error β
they are judged by, and the one RK4 step both are integrated with.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from mfi_drake.maths import fields
from mfi_drake.maths.constants import GRAVITY

if TYPE_CHECKING:  # annotations only: the maths layer needs no configuration
    from mfi_drake.config.parameters import NavigatorParams


def rk4_step(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, h: float):
    """One classical Runge–Kutta step of ẋ = f(x) of length h (x may hold
    many states as columns when f is vectorised)."""
    k1 = f(x)
    k2 = f(x + 0.5 * h * k1)
    k3 = f(x + 0.5 * h * k2)
    k4 = f(x + h * k3)
    return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def heading_error(v: np.ndarray, r_g: np.ndarray) -> np.ndarray:
    """β, the angle between the velocity and the goal direction [rad], per row
    (NaN where either is zero)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.sum(v * r_g, axis=1) / (
            np.linalg.norm(v, axis=1) * np.linalg.norm(r_g, axis=1)
        )
    return np.arccos(np.clip(cos, -1.0, 1.0))


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
            s = rk4_step(derivative, s, h)
        out.append(s)
    out = np.array(out)
    return heading_error(out[:, 3:6], goal - out[:, 0:3])


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
