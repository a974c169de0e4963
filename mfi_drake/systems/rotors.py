"""The motors between the mixer and the rotors: a first-order lag on each
rotor command (`Vehicle.motor_time_constant`), u̇ = (u_cmd − u)/τ, that
starts at the hover command so that a flight starts in balance."""

import numpy as np
from pydrake.systems.primitives import AffineSystem

from mfi_drake.maths.layout import ROTORS


def motor_lag(time_constant: float, hover_command: float) -> AffineSystem:
    """The lag as Drake's AffineSystem (so it converts to AutoDiffXd for
    `Linearize`): input the 4 rotor commands u_cmd, output the 4 the rotors
    deliver u (no feedthrough). Its state is x = u / h − 1 with h =
    `hover_command`, 0 at hover (the default), of order 1 for the
    integrator's error control where u in (rad/s)² is of order 1e5:
    ẋ = (u_cmd / h − 1 − x) / τ, u = h (x + 1)."""
    tau, h = float(time_constant), float(hover_command)
    eye = np.eye(ROTORS)
    return AffineSystem(
        A=-eye / tau,
        B=eye / (tau * h),
        f0=np.full(ROTORS, -1.0 / tau),
        C=h * eye,
        D=np.zeros((ROTORS, ROTORS)),
        y0=np.full(ROTORS, h),
    )
