"""Small-vector and SO(3) algebra used by the navigation fields (eq 6, 16, 17).

Every function accepts numpy arrays of float, AutoDiffXd or (where no branch
on a value is needed) symbolic Expression, so that the same code serves
simulation and linearisation (issue 5). Branches compare values, which
AutoDiffXd supports; they are documented where they exist.
"""

import math

import numpy as np

# Below this norm a direction is treated as undefined.
TINY = 1e-9


def _scalar_function(for_float, for_other):
    """A function of one scalar: `for_float` (math's, far cheaper than a
    numpy ufunc on one number) for floats, `for_other` (numpy's, which
    dispatches to AutoDiffXd's and Expression's own) otherwise."""
    return lambda x: for_float(x) if isinstance(x, float) else for_other(x)


sqrt = _scalar_function(math.sqrt, np.sqrt)
arccos = _scalar_function(math.acos, np.arccos)
floor = _scalar_function(math.floor, np.floor)


def atan2(y, x):
    """atan2 of two scalars (math's for floats, numpy's otherwise)."""
    return math.atan2(y, x) if isinstance(y, float) else np.arctan2(y, x)


sin = _scalar_function(math.sin, np.sin)
cos = _scalar_function(math.cos, np.cos)


def entries(a) -> list:
    """The entries of a small vector as a list of Python scalars.

    Arithmetic on Python floats is several times cheaper than on numpy
    scalars, and the simulation evaluates these functions thousands of
    times; AutoDiffXd and Expression entries pass through unchanged.
    """
    return a.tolist() if isinstance(a, np.ndarray) else list(a)


def dot(a: np.ndarray, b: np.ndarray):
    """a·b for 3-vectors (faster than np.dot on tiny or object arrays)."""
    a0, a1, a2 = entries(a)
    b0, b1, b2 = entries(b)
    return a0 * b0 + a1 * b1 + a2 * b2


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for 3-vectors."""
    a0, a1, a2 = entries(a)
    b0, b1, b2 = entries(b)
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def norm(a: np.ndarray):
    """Euclidean norm of a 3-vector."""
    a0, a1, a2 = entries(a)
    return sqrt(a0 * a0 + a1 * a1 + a2 * a2)


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
    # w = r_ref × u and c = cos φ = r_ref·u, on the entries.
    r0, r1, r2 = entries(r_ref)
    u0, u1, u2 = entries(u)
    w0, w1, w2 = r1 * u2 - r2 * u1, r2 * u0 - r0 * u2, r0 * u1 - r1 * u0
    c = r0 * u0 + r1 * u1 + r2 * u2
    k = 1.0 / (1.0 + c)
    k0, k1, k2 = k * w0, k * w1, k * w2
    # Entry by entry: cos φ δ_ij + hat(w)_ij + w_i w_j / (1 + cos φ), row by
    # row in one flat list (numpy builds that faster than nested rows).
    return np.array(
        [
            c + k0 * w0,
            k0 * w1 - w2,
            k0 * w2 + w1,
            k1 * w0 + w2,
            c + k1 * w1,
            k1 * w2 - w0,
            k2 * w0 - w1,
            k2 * w1 + w0,
            c + k2 * w2,
        ]
    ).reshape(3, 3)


# Fallback reference vectors r_ref for eq 16, in order of preference, used
# only when v and r_g point (nearly) opposite ways.
# Triples, not an array: numba reads a global array as read-only, of
# another type than the bisector's array `reference_axis` also returns.
_REFERENCE_CANDIDATES = (
    (0.0, 0.0, -1.0),
    (0.0, 0.0, 1.0),
    (1.0, 0.0, 0.0),
    (-1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
    (0.0, -1.0, 0.0),
)
# Minimum 1 + cos φ accepted for a fallback. With 0.3 one of the six always
# qualifies for any pair of unit vectors (a unit vector has at most two
# components of magnitude > 0.7).
_REFERENCE_MARGIN = 0.3
# |l_a + l_g| below which the bisector is not used (angle between > 174°).
_BISECTOR_MIN = 0.1


def _bisector(a, g) -> tuple | None:
    """(a + g)/|a + g| for the entries of unit vectors a and g, on Python
    scalars (cheaper than numpy on 3-vectors); None when |a + g| ≤
    _BISECTOR_MIN, where it is undefined for eq 16."""
    b0, b1, b2 = a[0] + g[0], a[1] + g[1], a[2] + g[2]
    size = sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    if size <= _BISECTOR_MIN:
        return None
    return (b0 / size, b1 / size, b2 / size)


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
    bisector = _bisector(entries(l_a), entries(l_g))
    if bisector is not None:
        b0, b1, b2 = bisector  # (numba: unpacking takes the tuple out of None's)
        return np.array([b0, b1, b2])
    for r_ref in _REFERENCE_CANDIDATES:
        if (
            1.0 + dot(r_ref, l_a) >= _REFERENCE_MARGIN
            and 1.0 + dot(r_ref, l_g) >= _REFERENCE_MARGIN
        ):
            return np.array(r_ref)
    raise AssertionError("unreachable: some axis always qualifies")


def bisector_turn(l_a: np.ndarray, l_g: np.ndarray) -> np.ndarray | None:
    """ω_ref / K_ω of eq 17–18 when r_ref is the bisector of the unit vectors
    l_a and l_g (see `reference_axis`); None where the bisector is undefined.

    R_v and R_g then turn about the same unit axis u = l_a × l_g / |l_a × l_g|,
    by −φ/2 and +φ/2 (φ the angle from l_a to l_g), so R_gᵀ R_v turns by −φ
    about u, log(R_gᵀ R_v) = −φ û, and ω_ref = R_g ω_g = K_ω φ u: eq 16–18
    without the two rotations and the logarithm.
    """
    a, g = entries(l_a), entries(l_g)
    if _bisector(a, g) is None:
        return None
    a0, a1, a2 = a
    g0, g1, g2 = g
    w0, w1, w2 = a1 * g2 - a2 * g1, a2 * g0 - a0 * g2, a0 * g1 - a1 * g0
    s = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    # φ / sin φ → 1 as the two align (φ < 174° here, so cos φ > 0 then).
    k = atan2(s, a0 * g0 + a1 * g1 + a2 * g2) / s if s > TINY else 1.0 + 0.0 * s
    return np.array([k * w0, k * w1, k * w2])


# 1 + cos φ below which `smooth_turn` blends in its fixed axis (φ > ~168°).
_OPPOSITE_BAND = 0.02


def smooth_turn(l_a: np.ndarray, l_g: np.ndarray) -> np.ndarray:
    """ω_ref / K_ω of eq 17–18 continuous up to opposite l_a and l_g.

    `bisector_turn`'s φ u (u = l_a × l_g / |l_a × l_g|) while 1 + cos φ ≥
    _OPPOSITE_BAND; below, the axis l_a × l_g is blended with a fixed one
    ⟂ l_a, a = e_z × l_a (+ 0.1 e_x × l_a, for a vertical l_a), whose weight
    grows linearly to 1 at l_a = −l_g, where the turn is π a/|a|: a level
    turn, the same way every time. The axis stays ⟂ l_a, so ω × v does no
    work; it is undefined only where l_a × l_g = −λ a (measure zero; there
    the bisector form is used).
    """
    a, g = entries(l_a), entries(l_g)
    a0, a1, a2 = a
    g0, g1, g2 = g
    w0, w1, w2 = a1 * g2 - a2 * g1, a2 * g0 - a0 * g2, a0 * g1 - a1 * g0
    s = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    c = a0 * g0 + a1 * g1 + a2 * g2
    phi = atan2(s, c)
    weight = 1.0 - (1.0 + c) / _OPPOSITE_BAND
    if weight > 0.0:  # e_z × l_a + 0.1 e_x × l_a
        w0, w1, w2 = (
            w0 + weight * (-a1),
            w1 + weight * (a0 - 0.1 * a2),
            w2 + weight * (0.1 * a1),
        )
        s = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if s <= TINY:
        turn = bisector_turn(l_a, l_g)
        return turn if turn is not None else np.array([0.0 * c] * 3)
    k = phi / s
    return np.array([k * w0, k * w1, k * w2])


def so3_log(R: np.ndarray) -> np.ndarray:
    """The matrix logarithm of eq 17, log R = hat(rotation_vector(R))."""
    return hat(rotation_vector(R))


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """Eq 17's logarithm as a vector: vee(log R) = β a for R = exp(β hat(a)),
    from log R = β / (2 sin β) (R − Rᵀ).

    β = arccos((tr R − 1) / 2). Two singular ends are handled:
    - β → 0: β / sin β is replaced by its series 1 + β²/6 with
      β² ≈ 2 (1 − cos β), which is smooth and exact at R = I;
    - β → π: R − Rᵀ vanishes, so the axis a is read from the symmetric part
      (R + Rᵀ)/2 = cos β I + (1 − cos β) a aᵀ, its sign chosen to agree with
      vee(R − Rᵀ) (or, exactly at π, to make a's largest entry positive).
    """
    # Entry by entry, on Python scalars (cheaper than small-array operations).
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = entries(R)
    c = (r00 + r11 + r22 - 1.0) / 2.0
    if c > 1.0:
        c = 1.0 + 0.0 * c
    elif c < -1.0:
        c = -1.0 + 0.0 * c
    # s = vee(R − Rᵀ) / 2 = sin β · a.
    s0 = (r21 - r12) / 2.0
    s1 = (r02 - r20) / 2.0
    s2 = (r10 - r01) / 2.0
    if c > 1.0 - 1e-6:
        k = 1.0 + (1.0 - c) / 3.0  # β / sin β
        return np.array([k * s0, k * s1, k * s2])
    beta = arccos(c)
    if c > -0.99:
        k = beta / sin(beta)
        return np.array([k * s0, k * s1, k * s2])
    # Near π: a aᵀ = (S − c I) / (1 − c).
    S = (R + R.T) / 2.0
    B = (S - c * np.eye(3)) / (1.0 - c)
    j = int(np.argmax(np.array([float(_value(B[i, i])) for i in range(3)])))
    a = B[:, j] / np.sqrt(B[j, j])
    s = [s0, s1, s2]
    if (
        float(_value(dot(a, s))) < 0.0
        or float(_value(dot(s, s))) == 0.0
        and float(_value(a[j])) < 0.0
    ):
        a = -a
    return beta * a


def _value(x):
    """The float value of a float or AutoDiffXd scalar."""
    return x.value() if hasattr(x, "value") else x
