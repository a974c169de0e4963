"""Small-vector and SO(3) algebra used by the navigation fields (eq 6, 16, 17).

Every function accepts numpy arrays of float, AutoDiffXd or (where no branch
on a value is needed) symbolic Expression, so that the same code serves
simulation and linearisation (issue 5). Branches compare values, which
AutoDiffXd supports; they are documented where they exist.
"""

import numpy as np

# Below this norm a direction is treated as undefined.
TINY = 1e-9


def dot(a: np.ndarray, b: np.ndarray):
    """a·b for 3-vectors (faster than np.dot on tiny object arrays)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for 3-vectors."""
    return np.array(
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    )


def norm(a: np.ndarray):
    """Euclidean norm of a 3-vector (np.sqrt dispatches to AutoDiffXd.sqrt)."""
    return np.sqrt(dot(a, a))


def hat(w: np.ndarray) -> np.ndarray:
    """The skew-symmetric matrix of eq 6: hat(w) @ x == w × x."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def vee(W: np.ndarray) -> np.ndarray:
    """Inverse of hat: the vector of a skew-symmetric matrix."""
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def rotation_from_reference(r_ref: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Eq 16: the Rodrigues rotation taking unit r_ref to unit u.

    R = I + hat(w) + hat(w)² / (1 + cos φ), w = r_ref × u, cos φ = r_ref·u.
    Since hat(w)² = w wᵀ − |w|² I and |w|² = 1 − cos² φ, this is evaluated as
    cos φ I + hat(w) + w wᵀ / (1 + cos φ) (same matrix, fewer products).
    Singular at u = −r_ref (1 + cos φ = 0); callers pick r_ref away from u
    (see `reference_axis`).
    """
    w = cross(r_ref, u)
    c = dot(r_ref, u)
    R = hat(w) + np.outer(w, w / (1.0 + c))
    R[0, 0] += c
    R[1, 1] += c
    R[2, 2] += c
    return R


# Fallback reference vectors r_ref for eq 16, in order of preference, used
# only when v and r_g point (nearly) opposite ways.
_REFERENCE_CANDIDATES = np.array(
    [
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
    ]
)
# Minimum 1 + cos φ accepted for a fallback. With 0.3 one of the six always
# qualifies for any pair of unit vectors (a unit vector has at most two
# components of magnitude > 0.7).
_REFERENCE_MARGIN = 0.3
# |l_a + l_g| below which the bisector is not used (angle between > 174°).
_BISECTOR_MIN = 0.1


def reference_axis(l_a: np.ndarray, l_g: np.ndarray) -> np.ndarray:
    """The reference r_ref of eq 16 for unit vectors l_a and l_g.

    The paper leaves r_ref free; the angle β of R_e does not depend on it,
    but its twist does, and with an arbitrary r_ref a level turn acquires a
    vertical force. The bisector (l_a + l_g)/|l_a + l_g| lies in the plane
    of l_a and l_g, so R_v and R_g turn about the same axis l_a × l_g and
    F_gc turns the heading straight toward the goal, with 1 + cos φ ≥ 1 for
    both. When the two are nearly opposite the bisector is undefined; then
    the first of six fixed axes with 1 + cos φ ≥ 0.3 for both is used.
    """
    bisector = l_a + l_g
    size = norm(bisector)
    if size > _BISECTOR_MIN:
        return bisector / size
    for r_ref in _REFERENCE_CANDIDATES:
        if (
            1.0 + dot(r_ref, l_a) >= _REFERENCE_MARGIN
            and 1.0 + dot(r_ref, l_g) >= _REFERENCE_MARGIN
        ):
            return r_ref
    raise AssertionError("unreachable: some axis always qualifies")


def so3_log(R: np.ndarray) -> np.ndarray:
    """The matrix logarithm of eq 17: log R = β / (2 sin β) (R − Rᵀ).

    β = arccos((tr R − 1) / 2). Two singular ends are handled:
    - β → 0: β / sin β is replaced by its series 1 + β²/6 with
      β² ≈ 2 (1 − cos β), which is smooth and exact at R = I;
    - β → π: R − Rᵀ vanishes, so the axis a is read from the symmetric part
      (R + Rᵀ)/2 = cos β I + (1 − cos β) a aᵀ, its sign chosen to agree with
      vee(R − Rᵀ) (or, exactly at π, to make a's largest entry positive).
    """
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0
    if c > 1.0:
        c = 1.0 + 0.0 * c
    elif c < -1.0:
        c = -1.0 + 0.0 * c
    A = (R - R.T) / 2.0  # = sin β · hat(a)
    if c > 1.0 - 1e-6:
        return (1.0 + (1.0 - c) / 3.0) * A
    beta = np.arccos(c)
    if c > -0.99:
        return (beta / np.sin(beta)) * A
    # Near π: a aᵀ = (S − c I) / (1 − c).
    S = (R + R.T) / 2.0
    B = (S - c * np.eye(3)) / (1.0 - c)
    j = int(np.argmax([float(_value(B[i, i])) for i in range(3)]))
    a = B[:, j] / np.sqrt(B[j, j])
    s = vee(A)
    if (
        float(_value(dot(a, s))) < 0.0
        or float(_value(dot(s, s))) == 0.0
        and float(_value(a[j])) < 0.0
    ):
        a = -a
    return beta * hat(a)


def _value(x):
    """The float value of a float or AutoDiffXd scalar."""
    return x.value() if hasattr(x, "value") else x
