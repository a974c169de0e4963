"""SDFormat's `<polyline>` geometry (a polygon of `<point>`s in the
collision's xy plane, extruded from z = 0 to `<height>`) as convex prisms:
the polygon cut into triangles by ear clipping, each triangle's prism one
convex piece, so a non-convex outline (Gazebo's polylines example: an
arrowhead) is flown exactly, not as its hull. A geometry of several
polylines is each one's solid (SDFormat does not say they are holes).
"""

import numpy as np

EPSILON = 1e-12  # m²: a smaller area is no area (a turn of collinear points)


def _outline(points: list[list[float]]) -> np.ndarray:
    """The polygon's corners, counter-clockwise, repeated and collinear
    corners left out. Raises ValueError where nothing is enclosed."""
    corners = np.asarray(points, dtype=float).reshape(-1, 2)
    kept = [c for k, c in enumerate(corners) if not np.allclose(c, corners[k - 1])]
    corners = np.array(kept).reshape(-1, 2)
    x, y = corners[:, 0], corners[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    if len(corners) < 3 or abs(area) <= EPSILON:
        raise ValueError("a polyline must enclose an area (3 or more points)")
    return corners if area > 0 else corners[::-1]


def _cross(o, a, b) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _inside(p, a, b, c) -> bool:
    """p in the counter-clockwise triangle abc, its edges included."""
    return min(_cross(a, b, p), _cross(b, c, p), _cross(c, a, p)) >= -EPSILON


def _crossing(corners: np.ndarray) -> bool:
    """Whether two edges of the polygon that share no corner cross."""
    n = len(corners)
    edges = [(corners[k], corners[(k + 1) % n]) for k in range(n)]
    for i in range(n):
        for j in range(i + 2, n - (i == 0)):
            (a, b), (c, d) = edges[i], edges[j]
            if (
                _cross(a, b, c) * _cross(a, b, d) < 0
                and _cross(c, d, a) * _cross(c, d, b) < 0
            ):
                return True
    return False


def triangles(points: list[list[float]]) -> list[np.ndarray]:
    """The polygon of `points` (x, y) as triangles (3, 2), by ear clipping.
    Raises ValueError for a polygon that crosses itself."""
    corners = _outline(points)
    if _crossing(corners):
        raise ValueError("a polyline must not cross itself")
    left = list(range(len(corners)))
    found = []
    while len(left) > 3:
        for k in range(len(left)):
            i, j, m = left[k - 1], left[k], left[(k + 1) % len(left)]
            a, b, c = corners[i], corners[j], corners[m]
            turn = _cross(a, b, c)
            if abs(turn) <= EPSILON:  # collinear: b is no corner
                left.pop(k)
                break
            others = (corners[n] for n in left if n not in (i, j, m))
            if turn > 0 and not any(_inside(p, a, b, c) for p in others):
                found.append(np.array([a, b, c]))
                left.pop(k)
                break
        else:  # a simple polygon always has an ear: rounding's
            raise ValueError("a polyline too thin to cut into triangles")
    found.append(corners[left])
    return found


def prisms(points: list[list[float]], height: float) -> list[np.ndarray]:
    """The polygon of `points` extruded from z = 0 to `height`: one prism's
    six corners (6, 3) a triangle."""
    return [
        np.vstack([np.column_stack([t, np.full(3, z)]) for z in (0.0, height)])
        for t in triangles(points)
    ]
