"""The layouts of the vectors that travel between systems, in one place.

State: Drake's QuadrotorPlant state (x, y, z, roll, pitch, yaw, ẋ, ẏ, ż,
roll̇, pitcḣ, yaẇ), world frame, z up, R = Rz(yaw) Ry(pitch) Rx(roll).

Obstacle reading: what every sensor sends the navigator. `readings`
readings [r_o (3), seen] (a sensor's parameter, default OBSTACLE_COUNT;
every port that carries them is `signal_size(readings)` long), nearest
first; r_o is the vector from the vehicle
centre to an obstacle's closest point (world frame, m) and seen is 1.0 when
that obstacle is in range, else 0.0 (with r_o = 0).
"""

import numpy as np

STATE_SIZE = 12
POSITION = slice(0, 3)
ATTITUDE = slice(3, 6)  # roll, pitch, yaw [rad]
VELOCITY = slice(6, 9)
ANGULAR_RATE = slice(9, 12)  # roll, pitch, yaw rates [rad/s]

ROTORS = 4

OBSTACLE_COUNT = 3  # default readings a sensor reports, nearest first
READING_SIZE = 4  # [r_o (3), seen]
OBSTACLE_SIGNAL_SIZE = READING_SIZE * OBSTACLE_COUNT  # at the default count


def signal_size(count: int) -> int:
    """The length of an "obstacle" signal of `count` readings."""
    return READING_SIZE * count


def reading_count(signal) -> int:
    """How many readings the "obstacle" signal `signal` holds (its length
    says: the compiled chain reads any count without a global)."""
    return len(signal) // READING_SIZE


def slices(parts) -> dict[str, slice]:
    """Where each of `parts`, (name, size) pairs laid end to end, lies in
    their concatenation."""
    out, start = {}, 0
    for name, size in parts:
        out[name] = slice(start, start + size)
        start += size
    return out


def position_velocity(x):
    """(p, v) of a state vector."""
    return x[POSITION], x[VELOCITY]


def nearest_first(distances, count: int = OBSTACLE_COUNT) -> list[int]:
    """The indices of the `count` least `distances` (a sequence),
    least first, a tie in the given order: how a sensor ranks the obstacles
    it reads. A selection over the few readings within r_s: in Python it
    costs what `sorted` does, where an argsort of a new array cost ~4 µs a
    reading (2.5 % of a planar-wall flight); numba compiles it as it is."""
    order = []
    for _ in range(min(count, len(distances))):
        best = -1
        for i in range(len(distances)):
            if (best < 0 or distances[i] < distances[best]) and i not in order:
                best = i
        order.append(best)
    return order


def point_readings(
    p: np.ndarray, points: np.ndarray, radius: float, count: int = OBSTACLE_COUNT
) -> np.ndarray:
    """The "obstacle" signal at p of the obstacles whose closest points are
    `points` (k, 3, world frame), as the sphere sensor reads them: those
    within `radius` of p (inclusive, as SceneGraph's threshold), nearest
    first. (SceneGraph ranks by signed distance: the same order unless p is
    inside an obstacle, which points cannot tell.)"""
    r_o = points - p
    distances = np.sqrt(np.sum(r_o * r_o, axis=1))
    within = distances <= radius
    return obstacle_signal(r_o[within][nearest_first(distances[within], count)], count)


def obstacle_signal(points, count: int = OBSTACLE_COUNT) -> np.ndarray:
    """The "obstacle" signal of `count` readings from up to `count` vectors
    r_o (a (k, 3) array or a sequence of triples), nearest first; the
    readings not filled are "nothing seen". Written as a list of floats
    and made an array once: a slice assignment a reading cost the sphere
    sensor ~1 µs each."""
    if isinstance(points, np.ndarray):
        points = points[:count].tolist()  # floats, not numpy scalars
    signal = [0.0] * signal_size(count)
    for i, r_o in enumerate(points[:count]):
        signal[READING_SIZE * i : READING_SIZE * (i + 1)] = (*r_o, 1.0)
    return np.array(signal, dtype=float)


def readings(signal):
    """The (r_o, seen) pairs of an "obstacle" signal, nearest first."""
    return [
        (signal[i : i + 3], signal[i + 3]) for i in range(0, len(signal), READING_SIZE)
    ]


def seen_points(signal) -> np.ndarray:
    """(k, 3): the r_o of the readings that see an obstacle, nearest first
    (what a user's field gets; written so that numba compiles it too)."""
    starts = [i for i in range(0, len(signal), READING_SIZE) if signal[i + 3] > 0.5]
    points = np.empty((len(starts), 3))
    for row, i in enumerate(starts):
        points[row] = signal[i : i + 3]
    return points
