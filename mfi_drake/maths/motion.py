"""Moving obstacles, as plain numpy: the closed form of an obstacle's
motion, and the estimate of an obstacle's velocity from successive
closest-point readings (docs/dynamic.md).

Motion. An obstacle at `position` with a `motion:` block is at

    position(t) = position + velocity·t + amplitude·sin(angular_frequency·t + phase)

per component, its orientation fixed: a pure translation.

Velocity from readings. A reading is r_o, the vector from the vehicle centre
p to the obstacle's closest point q = p + r_o. Between two readings h
seconds apart, q moves with the obstacle, and also slides over the surface as
the vehicle moves (round a static sphere, q follows the vehicle). Only the
motion along the surface normal n = r_o/|r_o| is the obstacle's: the sliding
is tangent to the surface, and for a translating convex obstacle
n·q̇ = n·u, with u its velocity. The tangential part of u cannot be seen in
one closest point (a sphere's spin looks like no motion at all), and it does
not change the distance. So the estimate is u ≈ n (n·(q_k − q_{k−1})/h), the
obstacle's normal velocity, exactly zero for a flat face and O(h) for a
curved static surface.
"""

import math

import numpy as np

from mfi_drake.maths.so3 import dot, entries, norm


def displacement(velocity, amplitude, angular_frequency, phase, t) -> np.ndarray:
    """position(t) − position: velocity·t + amplitude·sin(ω t + phase), per
    component. `t` a number → (3,); an array of N times → (N, 3)."""
    t = np.asarray(t, float)[..., None]
    velocity, amplitude = np.asarray(velocity, float), np.asarray(amplitude, float)
    omega, phase = np.asarray(angular_frequency, float), np.asarray(phase, float)
    return velocity * t + amplitude * np.sin(omega * t + phase)


def displacement_rate(velocity, amplitude, angular_frequency, phase, t) -> np.ndarray:
    """d/dt of `displacement`: velocity + amplitude·ω·cos(ω t + phase)."""
    t = np.asarray(t, float)[..., None]
    velocity, amplitude = np.asarray(velocity, float), np.asarray(amplitude, float)
    omega, phase = np.asarray(angular_frequency, float), np.asarray(phase, float)
    return velocity + amplitude * omega * np.cos(omega * t + phase)


def match_points(points: np.ndarray, before: np.ndarray, gate: float) -> list:
    """For each row of `points` (k, 3), the index of the row of `before`
    (m, 3) it continues, or None: pairs are taken nearest first (ties in
    row-major order), each row of either side at most once, and only closer
    than `gate`."""
    # On Python floats: k, m ≤ 3, and numpy on such tiny arrays costs more
    # than the arithmetic (this runs at every evaluation among moving
    # obstacles).
    new, old = points.tolist(), before.tolist()
    pairs = sorted(
        (math.dist(p, q), i, j) for i, p in enumerate(new) for j, q in enumerate(old)
    )
    matched: list = [None] * len(new)
    taken = set()
    for distance, i, j in pairs:
        if distance >= gate:
            break
        if matched[i] is None and j not in taken:
            matched[i] = j
            taken.add(j)
    return matched


def normal_velocity(r_o: np.ndarray, moved: np.ndarray, h: float) -> np.ndarray:
    """The obstacle's velocity along the normal at the reading r_o, from the
    closest point's displacement `moved` = q_k − q_{k−1} over h seconds:
    n (n·moved)/h with n = r_o/|r_o|."""
    return along_normal(r_o, moved) / h


def along_normal(r_o: np.ndarray, u: np.ndarray) -> np.ndarray:
    """u's component along the normal n = r_o/|r_o| (zero where r_o = 0: at
    the surface there is no normal to take)."""
    distance = norm(r_o)
    if distance == 0.0:
        return np.zeros(3)
    n = [x / distance for x in entries(r_o)]
    along = dot(n, u)
    return np.array([x * along for x in n])


def turned_right(w: np.ndarray, degrees: float) -> np.ndarray:
    """w turned `degrees` clockwise about e_z seen from above (to the right
    of a vehicle flying along w): the rule of the road of a fleet."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    x, y, z = entries(w)
    return np.array([c * x + s * y, c * y - s * x, z])


PACE_BLEND_SPEED = 0.3  # m/s, below which `keep_own_pace` fades to `own`


def keep_own_pace(
    relative: np.ndarray, own: np.ndarray, v: np.ndarray, blend_speed: float
) -> np.ndarray:
    """A field computed with the velocities relative to the obstacles
    (`relative`), less the part of its difference from the field computed
    with the vehicle's own velocity v (`own`) that lies along v: it steers
    as the relative field does and speeds up or brakes as the own one does.
    Below `blend_speed` it fades linearly to `own`: a vehicle holding a
    point (at rest v gives no direction) is flown as in a static scene."""
    speed = norm(v)
    if speed == 0.0:
        return own
    along = [x / speed for x in entries(v)]
    r, o = entries(relative), entries(own)
    k = dot([r[i] - o[i] for i in range(3)], along)
    w = min(1.0, speed / blend_speed)
    return np.array([o[i] + w * (r[i] - k * along[i] - o[i]) for i in range(3)])
