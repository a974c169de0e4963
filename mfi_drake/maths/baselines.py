"""The paper's two baselines (§VI-A), as plain numpy functions beside `fields`.

- APF, the artificial potential field of Khatib (the paper's ref [20]):
  F = −∇U_att − k_d ṗ + F_rep, with F_rep = −∇U_rep.
- GF, the gyroscopic force in the Chang–Marsden line (refs [13]–[14]):
  F = −∇U_att − k_d ṗ + S ṗ + F_rep, with S skew-symmetric (no work).

Both share the goal attraction `attraction_field`: eq 20's PD −k_att (p − p_g)
− k_d ṗ near the goal, with Khatib's velocity limit far from it (the
attractive potential turns from a quadratic into a cone at d* = k_d v_max /
k_att, so the vehicle cruises at v_max there). The repulsion is Khatib's
U_rep = ½ η (1/r − 1/ρ₀)² for r < ρ₀.

Notation as in `fields`: r_o is the vector from the vehicle centre to the
closest obstacle point, n = r_o/|r_o|, r = |r_o| − collision radius (the
obstacle grown by the vehicle), r_g = p_g − p. Forces in newtons, world frame.
Every function works on float and AutoDiffXd arrays.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mfi_drake.maths.fields import fallback_tangent, heading
from mfi_drake.maths.so3 import TINY, dot, norm

if TYPE_CHECKING:  # annotations only: the maths layer needs no configuration
    from mfi_drake.config.parameters import ApfParams, AttractionParams, GfParams


# --- goal attraction (both baselines) ----------------------------------------
def attraction_potential(p: np.ndarray, goal: np.ndarray, a: AttractionParams):
    """U_att [J]: ½ k_att d² for d ≤ d*, k_att d* (d − d*/2) beyond (d = |p − p_g|)."""
    d = norm(p - goal)
    d_star = a.cone_radius
    if d <= d_star:
        return 0.5 * a.k_att * d * d
    return a.k_att * d_star * (d - 0.5 * d_star)


def attraction_field(
    p: np.ndarray, v: np.ndarray, goal: np.ndarray, a: AttractionParams
) -> np.ndarray:
    """−∇U_att − k_d ṗ: eq 20's −k_att (p − p_g) − k_d ṗ within d* of the goal,
    −k_d v_max (p − p_g)/|p − p_g| − k_d ṗ beyond (Khatib's velocity limit)."""
    e = p - goal
    d = norm(e)
    d_star = a.cone_radius
    if d <= d_star:
        return -a.k_att * e - a.k_d * v
    return -(a.k_att * d_star / d) * e - a.k_d * v


def attraction_terms(mode, p, v, goal, params, F_o=None, mass=None) -> tuple:
    """The baselines' goal part laid out as `fields.goal_terms`' (F_gc, F_v,
    F_pd), for a chain that takes either: (0, 0, `attraction_field` of
    `params.attraction`), whatever eq 21's `mode`, F_o and mass (the
    baselines have no cruise mode)."""
    zero = 0.0 * v
    return zero, zero, attraction_field(p, v, goal, params.attraction)


# --- repulsion (both baselines) -----------------------------------------------
def repulsive_potential(r, eta: float, rho_0: float):
    """Khatib's U_rep = ½ η (1/r − 1/ρ₀)² for r < ρ₀, else 0 [J]."""
    if r >= rho_0:
        return 0.0 * r
    return 0.5 * eta * (1.0 / r - 1.0 / rho_0) ** 2


def repulsive_field(n: np.ndarray, r, eta: float, rho_0: float) -> np.ndarray:
    """−∇U_rep = η (1/r − 1/ρ₀) (1/r²) (−n) for r < ρ₀ (∇r = −n), else 0."""
    if r >= rho_0:
        return 0.0 * n
    return -(eta * (1.0 / r - 1.0 / rho_0) / (r * r)) * n


def _closest(r_o: np.ndarray, seen, collision_radius: float, min_distance: float):
    """(n, r) of a seen obstacle, r floored at min_distance; None when nothing
    is seen or the obstacle point is the vehicle centre (n undefined)."""
    distance = norm(r_o)
    if seen <= 0.5 or distance < TINY:
        return None
    r = distance - collision_radius
    if r < min_distance:
        r = min_distance + 0.0 * r
    return r_o / distance, r


def apf_obstacle_field(
    v: np.ndarray,
    r_o: np.ndarray,
    seen,
    r_g: np.ndarray,
    collision_radius: float,
    params: ApfParams,
) -> tuple[np.ndarray, np.ndarray]:
    """APF's obstacle part as (F_rep, 0), F_rep = −∇U_rep (zero when nothing
    is seen). The signature is `fields.obstacle_field`'s; a potential field
    depends on neither v nor r_g."""
    zero = 0.0 * r_o
    closest = _closest(r_o, seen, collision_radius, params.min_distance)
    if closest is None:
        return zero, zero
    n, r = closest
    return repulsive_field(n, r, params.eta, params.rho_0), zero


# --- gyroscopic steering (GF) -------------------------------------------------
def steering_direction(
    l_a: np.ndarray, n: np.ndarray, r_g: np.ndarray, blend: float
) -> np.ndarray:
    """The unit direction ⟂ l_a that turns the heading away from the obstacle:
    −n⊥/|n⊥| with n⊥ = n − (l_a·n) l_a.

    Head-on (|n⊥| < blend) n⊥ says nothing, so the deterministic
    `fields.fallback_tangent` t (goal side, else horizontal), made ⟂ l_a and
    signed to agree with −n⊥, is blended in: −n⊥ + (blend − |n⊥|) t, which is
    never zero and equals −n⊥ at |n⊥| = blend.
    """
    d = dot(l_a, n) * l_a - n
    size = norm(d)
    if size < blend:
        t = fallback_tangent(n, r_g)
        t = t - dot(t, l_a) * l_a
        t = t / norm(t)
        if dot(d, t) < 0.0:
            t = -t
        d = d + (blend - size) * t
    return d / norm(d)


def gyroscopic_matrix(
    v: np.ndarray, n: np.ndarray, r, r_g: np.ndarray, params: GfParams
) -> np.ndarray:
    """The skew-symmetric S of GF's force S ṗ [N·s/m] (3×3).

    S = k_g (1/r − 1/r_d) (l_a·n) (d l_aᵀ − l_a dᵀ) with d the
    `steering_direction`, so S ṗ = k_g |ṗ| (1/r − 1/r_d) (l_a·n) d: ⟂ ṗ, away
    from the obstacle, only inside the detection shell (r < r_d) and only while
    approaching (l_a·n > 0), fading to zero at the shell and when grazing.
    """
    speed, l_a = heading(v)
    along = dot(l_a, n)
    if speed < TINY or r >= params.r_d or along <= 0.0:
        return 0.0 * np.outer(v, v)
    d = steering_direction(l_a, n, r_g, params.tangent_blend)
    gain = params.k_g * (1.0 / r - 1.0 / params.r_d) * along
    return gain * (np.outer(d, l_a) - np.outer(l_a, d))


def gf_obstacle_field(
    v: np.ndarray,
    r_o: np.ndarray,
    seen,
    r_g: np.ndarray,
    collision_radius: float,
    params: GfParams,
) -> tuple[np.ndarray, np.ndarray]:
    """GF's obstacle part as (S ṗ, F_rep); both zero when nothing is seen."""
    zero = 0.0 * v
    closest = _closest(r_o, seen, collision_radius, params.min_distance)
    if closest is None:
        return zero, zero
    n, r = closest
    S = gyroscopic_matrix(v, n, r, r_g, params)
    return S @ v, repulsive_field(n, r, params.eta, params.rho_0)
