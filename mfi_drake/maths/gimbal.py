"""Where a gimballed camera looks (docs/depth_camera.md, "Gimbal"): the
gimbal's orientation from its pan and tilt, and how far it turns toward
the vehicle's velocity in one frame."""

import math

import numpy as np


def gimbal_rotation(pan: float, tilt: float) -> np.ndarray:
    """R_WG of a pan–tilt gimbal: its +x turned `pan` about world z from
    world +x and raised `tilt` above the horizon, its +y horizontal."""
    cp, sp = math.cos(pan), math.sin(pan)
    ct, st = math.cos(tilt), math.sin(tilt)
    return np.array([[cp * ct, -sp, -cp * st], [sp * ct, cp, -sp * st], [st, 0.0, ct]])


def point_gimbal(
    angles: np.ndarray, velocity: np.ndarray, max_step: float, min_speed: float
) -> np.ndarray:
    """(pan, tilt) [rad] moved toward the direction of `velocity`, each by at
    most `max_step`. Below `min_speed` the direction is noise: held; so is
    the pan when the horizontal speed is below it (climbing straight up).
    Scalar `math`: called once a frame, where numpy's overhead would show."""
    pan, tilt = float(angles[0]), float(angles[1])
    vx, vy, vz = (float(v) for v in velocity[:3])
    horizontal = math.hypot(vx, vy)
    if math.hypot(horizontal, vz) < min_speed:
        return np.array([pan, tilt])
    tilt += min(max(math.atan2(vz, horizontal) - tilt, -max_step), max_step)
    if horizontal >= min_speed:
        error = _wrap(math.atan2(vy, vx) - pan)  # the shorter way round
        pan = _wrap(pan + min(max(error, -max_step), max_step))
    return np.array([pan, tilt])


def _wrap(angle: float) -> float:
    """`angle` [rad] in [-π, π)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi
