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

from mfi_drake.maths.fields import superposed
from mfi_drake.maths.layout import (
    POSITION,
    READING_SIZE,
    VELOCITY,
    nearest_first,
    reading_count,
)
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
    r0, r1, r2 = entries(r_o)
    n = (r0 / distance, r1 / distance, r2 / distance)
    along = dot(n, u)
    return np.array([n[0] * along, n[1] * along, n[2] * along])


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
    v0, v1, v2 = entries(v)
    along = (v0 / speed, v1 / speed, v2 / speed)
    r, o = entries(relative), entries(own)
    k = dot((r[0] - o[0], r[1] - o[1], r[2] - o[2]), along)
    w = min(1.0, speed / blend_speed)
    return np.array(
        [
            o[0] + w * (r[0] - k * along[0] - o[0]),
            o[1] + w * (r[1] - k * along[1] - o[1]),
            o[2] + w * (r[2] - k * along[2] - o[2]),
        ]
    )


def relative_field(
    field,
    x: np.ndarray,
    obstacle: np.ndarray,
    u: np.ndarray,
    turns: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    params,
    own_pace: bool,
    blend_speed: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(F_o, [A, B]) of an obstacle field `field` (`fields.superposed`'s)
    summed over the readings, each seen reading's terms computed alone with
    the velocity relative to its obstacle, v − u_i (u: 3 per reading),
    turned `turns[i]` degrees right (`turned_right`, the rule of the road;
    0 for an obstacle). With `own_pace` the force and each term keep the
    pace of the field computed with v itself (`keep_own_pace`). Nothing
    seen: zero, as `superposed` gives."""
    force, terms = np.zeros(3), np.zeros(6)
    p, v = x[POSITION], x[VELOCITY]
    r_g = goal - p
    seen = False
    for i in range(reading_count(obstacle)):
        if obstacle[READING_SIZE * i + 3] <= 0.5:
            continue
        seen = True
        w = v - u[3 * i : 3 * i + 3]
        if turns[i]:
            w = turned_right(w, turns[i])
        # `layout.obstacle_signal` of this reading alone, written out: its
        # list of points cost the compiled fleet chain ~10 %.
        alone = np.zeros(len(obstacle))
        alone[0:3] = obstacle[READING_SIZE * i : READING_SIZE * i + 3]
        alone[3] = 1.0
        A, B = superposed(field, w, alone, r_g, collision_radius, params)
        force = force + (A + B)
        terms = terms + np.concatenate((A, B))
    if not seen or not own_pace:
        return force, terms
    A, B = superposed(field, v, obstacle, r_g, collision_radius, params)
    own = np.concatenate((A, B))
    paced = np.concatenate(
        (
            keep_own_pace(terms[0:3], own[0:3], v, blend_speed),
            keep_own_pace(terms[3:6], own[3:6], v, blend_speed),
        )
    )
    return keep_own_pace(force, A + B, v, blend_speed), paced


def _length(x, y, z):
    """|(x, y, z)| (`maths.compiled` replaces it: numba's hypot takes two)."""
    return math.hypot(x, y, z)


def vehicle_readings(
    p: np.ndarray,
    scene: np.ndarray,
    scene_u: np.ndarray,
    centres: np.ndarray,
    velocities: np.ndarray,
    radius: float,
    reach: float,
    itself: int = -1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A sphere sensor's readings at p with other vehicles added: the
    nearest of the scene's readings `scene` (as many as it holds) and of the
    spheres of radius `radius` at `centres` (m, 3) within `reach` of the
    sphere around p (a sphere's closest point, as SceneGraph gives it: r_o =
    (|d| − ρ) d/|d|, d from p to the centre), nearest first (ties: the
    scene's first, then the vehicles in order); `centres[itself]` is the
    vehicle's own (−1: none there). Returns (the readings, per
    reading its vehicle's velocity along the reading's normal
    (`along_normal`, 3 each; a scene reading's its entry of `scene_u`,
    3 a reading of `scene`: zeros where the scene stands still, an
    `ObstacleVelocityEstimator`'s estimate among moving obstacles), per
    reading 1 where it is a vehicle, else 0)."""
    m, count = len(centres), reading_count(scene)
    gaps = np.zeros(count + m)
    points = np.zeros((count + m, 3))
    moving = np.full(count + m, -1)  # the vehicle's index, or −1
    slot = np.full(count + m, -1)  # the scene reading's slot, or −1
    found = 0
    for i in range(count):
        j = READING_SIZE * i
        if scene[j + 3] > 0.5:
            gaps[found] = _length(scene[j], scene[j + 1], scene[j + 2])
            points[found] = scene[j : j + 3]
            slot[found] = i
            found += 1
    statics = found
    limit = (reach + radius) ** 2
    for k in range(m):
        d0, d1, d2 = centres[k, 0] - p[0], centres[k, 1] - p[1], centres[k, 2] - p[2]
        if k == itself or d0 * d0 + d1 * d1 + d2 * d2 > limit:
            continue
        length = _length(d0, d1, d2)
        gaps[found] = length - radius
        if length > 0.0:
            scale = gaps[found] / length
            points[found] = (d0 * scale, d1 * scale, d2 * scale)
        moving[found] = k
        found += 1
    vehicle = np.zeros(count)
    if found == statics:
        return scene, scene_u.copy(), vehicle
    u = np.zeros(3 * count)
    signal = np.zeros(len(scene))
    for i, c in enumerate(nearest_first(gaps[:found], count)):
        signal[READING_SIZE * i : READING_SIZE * i + 3] = points[c]
        signal[READING_SIZE * i + 3] = 1.0
        if moving[c] >= 0:
            u[3 * i : 3 * i + 3] = along_normal(points[c], velocities[moving[c]])
            vehicle[i] = 1.0
        else:
            u[3 * i : 3 * i + 3] = scene_u[3 * slot[c] : 3 * slot[c] + 3]
    return signal, u, vehicle
