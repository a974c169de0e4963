"""The navigation field F_n of the paper's §IV, as plain numpy functions.

All forces are in the world frame, in newtons. Every function takes and
returns 3-vectors of float or AutoDiffXd (see `so3`), never Drake systems.

Notation (docs/design.md): v velocity, l_a = v/|v|, r_o the vector from the robot
centre to the closest obstacle point, n = r_o/|r_o|, r the distance from the
robot's collision sphere to the obstacle (|r_o| minus the collision radius),
r_g = p_g − p.

Eq 11–15 (the obstacle field) and eq 16–21 (goal attraction and the mode
switch) are here, the repairs (a)–(h) beside the terms they change; the
terminal approach (repair (i)) is `maths.terminal`, the triple arithmetic
`maths.triples`. docs/design.md maps every equation to its function.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mfi_drake.maths.layout import readings
from mfi_drake.maths.so3 import (
    TINY,
    bisector_turn,
    dot,
    entries,
    norm,
    reference_axis,
    rotation_from_reference,
    rotation_vector,
    smooth_turn,
)
from mfi_drake.maths.terminal import terminal_weight
from mfi_drake.maths.triples import _cross, _divided, _ramp, _scaled, _zero3, _zeros

if TYPE_CHECKING:  # annotations only: the maths layer needs no configuration
    from mfi_drake.config.parameters import NavigatorParams

E_X = (1.0, 0.0, 0.0)
E_Z = (0.0, 0.0, 1.0)


def _heading(v) -> tuple:
    speed = norm(v)
    if speed < TINY:
        return speed, _zeros(v[0])
    return speed, _divided(v, speed)


def heading(v: np.ndarray):
    """(speed, l_a); l_a = 0 when the speed is below TINY (eq 12's l_a)."""
    speed, l_a = _heading(entries(v))
    return speed, np.array(l_a)


def _fallback_tangent(n, r_g) -> tuple:
    along = dot(r_g, n)
    t = (r_g[0] - along * n[0], r_g[1] - along * n[1], r_g[2] - along * n[2])
    t_norm = norm(t)
    if t_norm > 0.1 * norm(r_g) and t_norm > TINY:
        return _divided(t, t_norm)
    t = _cross(E_Z, n)
    t_norm = norm(t)
    if t_norm > 0.1:
        return _divided(t, t_norm)
    t = _cross(E_X, n)
    return _divided(t, norm(t))


def fallback_tangent(n: np.ndarray, r_g: np.ndarray) -> np.ndarray:
    """A deterministic unit tangent to the obstacle at the closest point.

    Used when the robot heads straight at the obstacle and eq 11's current
    vanishes. Preference: the goal direction projected onto the tangent plane
    (go round on the goal's side); else horizontal, e_z × n (go round, not
    over); else e_x × n (n vertical).
    """
    return np.array(_fallback_tangent(entries(n), entries(r_g)))


def _continuous_tangent(n, r_g) -> tuple:
    """A unit tangent to the obstacle at the closest point that varies
    continuously with n and the goal (repair (b)): the goal direction
    projected on the tangent plane (go round on the goal's side) plus a small
    fixed horizontal bias e_z × n (go round to the left when the goal is
    straight behind) and a smaller e_x × n (for a vertical n). The sum is
    zero only on a set of measure zero, where `fallback_tangent` is used.
    Takes and returns triples (`so3.entries`)."""
    distance = norm(r_g)
    l_g = _divided(r_g, distance) if distance > TINY else _zeros(n[0])
    along = dot(l_g, n)
    z, x = _cross(E_Z, n), _cross(E_X, n)
    t = (
        ((l_g[0] - along * n[0]) + 0.1 * z[0]) + 0.01 * x[0],
        ((l_g[1] - along * n[1]) + 0.1 * z[1]) + 0.01 * x[1],
        ((l_g[2] - along * n[2]) + 0.1 * z[2]) + 0.01 * x[2],
    )
    size = norm(t)
    return _divided(t, size) if size > TINY else _fallback_tangent(n, r_g)


def _artificial_current(l_a, n, r_g, blend: float, continuous: bool) -> tuple:
    along = dot(l_a, n)
    l_o = (l_a[0] - along * n[0], l_a[1] - along * n[1], l_a[2] - along * n[2])
    size = norm(l_o)
    if along > 0.0 and size < blend:
        if continuous:
            t = _continuous_tangent(n, r_g)
            side = (dot(l_o, t) + 0.05 * blend) / (0.1 * blend)
            d = _scaled(t, min(1.0, max(-1.0, side)))
        else:
            d = _fallback_tangent(n, r_g)
            if dot(l_o, d) < 0.0:
                d = (-d[0], -d[1], -d[2])
        k = blend - size
        l_o = (l_o[0] + k * d[0], l_o[1] + k * d[1], l_o[2] + k * d[2])
    return l_o


def artificial_current(
    l_a: np.ndarray,
    n: np.ndarray,
    r_g: np.ndarray,
    blend: float,
    continuous: bool = False,
) -> np.ndarray:
    """Eq 11: l_o = l_a − (l_a·n) n, the heading projected on the surface.

    Head-on (l_a·n > 0 and |l_o| < blend) the current is lengthened along a
    deterministic tangent: l_o + (blend − |l_o|) d, which equals eq 11 at
    |l_o| = blend. The paper's form takes d = ±`fallback_tangent` (the goal's
    side, else horizontal), signed to agree with l_o: never zero, but its
    side flips with the sign of l_o·t however small l_o is (a 1e-9 change of
    heading). `continuous` takes d = σ t, t = `_continuous_tangent` and σ =
    clip((l_o·t + blend/20) / (blend/10), −1, 1): the same side as the paper
    outside a band |l_o·t + blend/20| < blend/10, and continuous across it.
    The current is never zero: where σ = 0, |l_o| ≥ blend/20.
    Receding from the obstacle, eq 11 is used as it is.
    """
    return np.array(
        _artificial_current(entries(l_a), entries(n), entries(r_g), blend, continuous)
    )


# Repair (h): approaching, eq 12's weight rises from 0 to 1 as the heading
# line's clearance from the closest point falls from AHEAD_MISS[1] to
# AHEAD_MISS[0] [m]. (It was the larger of that and a ramp of the approach
# angle l_a·n; the angle made far obstacles beside a clear line bend the path,
# docs/comparison.md.)
AHEAD_MISS = (0.5, 1.0)


def _blocking_weight(l_a, n, r_g, r_o=None, radius=0.0):
    along = dot(l_a, n)
    if along >= 0.0:
        if r_o is None:
            return 1.0
        # The heading line's clearance from the closest point, |r_o × l_a| − ρ.
        miss = norm(_cross(r_o, l_a)) - radius
        return _ramp(miss, AHEAD_MISS[1], AHEAD_MISS[0])
    distance = norm(r_g)
    if distance < TINY:
        return 0.0
    return min(1.0, max(0.0, 10.0 * dot(r_g, n) / distance))


def blocking_weight(
    l_a: np.ndarray,
    n: np.ndarray,
    r_g: np.ndarray,
    r_o: np.ndarray | None = None,
    radius: float = 0.0,
):
    """Repair (a): the weight of eq 12 for an obstacle. 1 while the vehicle
    approaches it (l_a·n ≥ 0); receding, 1 only if it lies toward the goal,
    n·l_g ≥ 0.1, fading to 0 at n·l_g = 0. Continuous: eq 12 vanishes at
    l_a·n = 0 whatever the weight. Given the closest point r_o (repair (h)),
    an approached obstacle weighs the ramp of m from 0 at m = AHEAD_MISS[1]
    to 1 at AHEAD_MISS[0], m = |r_o × l_a| − `radius` the clearance [m] by
    which the heading line passes the closest point: eq 12 turns the vehicle
    round obstacles in or near its path, and leaves those it passes wide to
    eq 14."""
    r_o = None if r_o is None else entries(r_o)
    return _blocking_weight(entries(l_a), entries(n), entries(r_g), r_o, radius)


def boundary_following(
    l_a, l_o, speed, r, c: float, r_l: float, tapered: bool = False
) -> tuple:
    """Eq 12–13: F = c · l_a × (l_o × l_a) · f, f = v/r if r < r_l else 0;
    `tapered` (repair (f)): f = v (1/r − 1/r_l), continuous at r_l.
    Takes and returns triples (`so3.entries`).

    Perpendicular to l_a, so it does no work.
    """
    if r >= r_l:
        return _zeros(l_a[0])
    k = c * speed * (1.0 / r - 1.0 / r_l) if tapered else c * speed / r
    return _scaled(_cross(l_a, _cross(l_o, l_a)), k)


def collision_avoidance(l_a, n, l_o, r, c_perp: float, r_b: float) -> tuple:
    """Eq 14–15: F_a = l_a × (n × l_o⊥) · f_a, l_o⊥ = −l_o,
    f_a = c⊥ (1/r − 1/r_b) / r² if r < r_b else 0. Takes and returns
    triples (`so3.entries`).

    Perpendicular to l_a (no work); turns the heading away from the surface.
    """
    if r >= r_b:
        return _zeros(l_a[0])
    f_a = c_perp * (1.0 / r - 1.0 / r_b) / (r * r)
    return _scaled(_cross(l_a, _cross(l_o, n)), f_a)  # n × l_o⊥ = l_o × n


def obstacle_field(
    v: np.ndarray,
    r_o: np.ndarray,
    seen,
    r_g: np.ndarray,
    collision_radius: float,
    params: NavigatorParams,
) -> tuple[np.ndarray, np.ndarray]:
    """F_o = F + F_a (eq 11–15); returns (F, F_a).

    Zero when nothing is seen (`seen` ≤ 0.5), when the robot is at rest, or
    when the obstacle point coincides with the robot centre (n undefined).
    r = |r_o| − collision_radius is floored at params.min_distance.
    """
    if seen <= 0.5:
        zero = _zero3(v)
        return zero, zero
    r_o = entries(r_o)
    distance = norm(r_o)
    r = distance - collision_radius
    # Beyond r_l the obstacle is beyond both ranges (r_b < r_l).
    if distance < TINY or r >= params.r_l:
        zero = _zero3(v)
        return zero, zero
    speed, l_a = _heading(entries(v))
    if speed < TINY:
        zero = _zero3(v)
        return zero, zero
    if r < params.min_distance:
        r = params.min_distance + 0.0 * r
    n = _divided(r_o, distance)
    r_g = entries(r_g)
    l_o = _artificial_current(l_a, n, r_g, params.tangent_blend, params.continuous_side)
    F = boundary_following(
        l_a, l_o, speed, r, params.c, params.r_l, params.tapered_range
    )
    if params.follow_blocking_only:
        ahead = r_o if params.follow_ahead_only else None
        weight = _blocking_weight(l_a, n, r_g, ahead, collision_radius)
        F = _scaled(F, weight)
    F_a = collision_avoidance(l_a, n, l_o, r, params.c_perp, params.r_b)
    if params.hover_fade and speed < params.fade_speed:
        F_a = _scaled(F_a, speed / params.fade_speed)
    return np.array(F), np.array(F_a)


def without_push_toward(F: np.ndarray, m: np.ndarray) -> np.ndarray:
    """F less its component along unit m when that component is positive."""
    along = dot(F, m)
    return F - along * m if along > 0.0 else F


def superposed(field, v, obstacle, r_g, collision_radius: float, params):
    """The terms (A, B) of an obstacle field, `field(v, r_o, seen, r_g,
    collision_radius, params)` (e.g. `obstacle_field`), summed over the
    readings [r_o, seen] of the "obstacle" signal (see `layout`), nearest
    first.

    The fields of separate surface currents add: each obstacle contributes
    eq 11–15 with its own closest point. With `params.project_others`
    (repair (c); MFI's parameters only), every obstacle after the nearest
    loses the part of its first term (MFI: eq 12's boundary following) that
    pushes toward the nearest one, m = the nearest's n made ⟂ v: the term
    stays ⟂ v (zero work), and only the nearest obstacle's own field turns
    the heading toward it. The second terms (eq 14's collision avoidance)
    are all kept: each guards against its own obstacle, also in a gap.
    Each obstacle's terms are first weighed by `terminal_weight` (the
    terminal approach; 1 where it is off or far from the goal).
    """
    A = B = _zero3(v)
    nearest = True
    m = None  # toward the nearest obstacle, across v (repair (c))
    for r_o, seen in readings(obstacle):
        if seen <= 0.5:  # unseen: its terms are zero; skip the call
            continue
        A_i, B_i = field(v, r_o, seen, r_g, collision_radius, params)
        fade = terminal_weight(r_o, r_g, collision_radius, params)
        A_i, B_i = fade * A_i, fade * B_i
        if nearest and getattr(params, "project_others", False):
            m = _toward_across(r_o, v)
        elif m is not None:  # boundary following only: each B_i guards its own
            A_i = without_push_toward(A_i, m)
        nearest = False
        A, B = A + A_i, B + B_i
    return A, B


def _toward_across(r_o: np.ndarray, v: np.ndarray) -> np.ndarray | None:
    """The unit direction toward the obstacle at r_o within the plane ⟂ v
    (None where it is undefined: v = 0, or r_o ∥ v)."""
    speed, l_a = heading(v)
    m = r_o - dot(r_o, l_a) * l_a
    size = norm(m)
    return m / size if speed > TINY and size > TINY else None


def _goal_attraction(v, speed, l_a, r_g, K_omega: float, smooth: bool) -> tuple:
    distance = norm(r_g)
    if speed < TINY or distance < TINY:
        return _zeros(v[0])
    l_g = _divided(r_g, distance)
    if smooth:
        return _scaled(_cross(entries(smooth_turn(l_a, l_g)), v), K_omega)
    return _paper_attraction(v, l_a, l_g, K_omega)


def _paper_attraction(v, l_a, l_g, K_omega: float) -> tuple:
    """Eq 16–18 as the paper turns (`goal_attraction_field` without
    `smooth`)."""
    turn = bisector_turn(l_a, l_g)
    if turn is not None:
        return _scaled(_cross(entries(turn), v), K_omega)
    r_ref = reference_axis(l_a, l_g)
    R_v = rotation_from_reference(r_ref, l_a)
    R_g = rotation_from_reference(r_ref, l_g)
    omega_g = -K_omega * rotation_vector(R_g.T @ R_v)  # ω̂_g = −K_ω log(R_gᵀ R_v)
    return _cross(entries(R_g @ omega_g), v)


def goal_attraction_field(
    v: np.ndarray, r_g: np.ndarray, K_omega: float, smooth: bool = False
):
    """Eq 16–18: F_gc = ω_ref × v with ω̂_g = −K_ω log(R_gᵀ R_v), ω_ref = R_g ω_g.

    R_v and R_g are eq 16's rotations from r_ref to l_a and to r_g/|r_g|;
    r_ref is chosen by `so3.reference_axis`: the bisector of l_a and l_g,
    where eq 16–18 reduce to the closed form `so3.bisector_turn`, else a
    fixed axis. With `smooth` (repair (e)) the turn is `so3.smooth_turn`,
    continuous up to l_a = −l_g. Zero when v = 0 or r_g = 0. Perpendicular
    to v (no work).
    """
    v = entries(v)
    speed, l_a = _heading(v)
    return np.array(_goal_attraction(v, speed, l_a, entries(r_g), K_omega, smooth))


def _speed_control(speed, l_a, K_v: float, v_d: float) -> tuple:
    return _scaled(l_a, -K_v * (speed - v_d))


def speed_control_field(v: np.ndarray, K_v: float, v_d: float) -> np.ndarray:
    """Eq 19: F_v = −K_v (|v| − v_d) l_a (zero at rest, where l_a is undefined)."""
    return np.array(_speed_control(*_heading(entries(v)), K_v, v_d))


def terminal_pd_field(
    p: np.ndarray, v: np.ndarray, goal: np.ndarray, params: NavigatorParams
) -> np.ndarray:
    """Eq 20: F_pd = −K_P (p − p_g) − K_D ṗ, its norm saturated at max_pd_force."""
    k_p, k_d = -params.K_P, params.K_D
    p, v, goal = entries(p), entries(v), entries(goal)
    F = (
        k_p * (p[0] - goal[0]) - k_d * v[0],
        k_p * (p[1] - goal[1]) - k_d * v[1],
        k_p * (p[2] - goal[2]) - k_d * v[2],
    )
    size = norm(F)
    if size > params.max_pd_force:
        F = _scaled(F, params.max_pd_force / size)
    return np.array(F)


def _distance_to_goal(p: np.ndarray, goal: np.ndarray):
    """|r_g| = |p_g − p|."""
    (p0, p1, p2), (g0, g1, g2) = entries(p), entries(goal)
    return norm((g0 - p0, g1 - p1, g2 - p2))


# Eq 21's two modes.
MODE_PD = 0
MODE_CRUISE = 1


def cruise_guard(p: np.ndarray, v: np.ndarray, goal: np.ndarray, params):
    """≥ 0 where eq 21 may leave PD for cruise: v ≥ v_min and |r_g| ≥ r_gl + h."""
    return min(
        norm(v) - params.v_min,
        _distance_to_goal(p, goal) - (params.r_gl + params.goal_hysteresis),
    )


def pd_guard(p: np.ndarray, v: np.ndarray, goal: np.ndarray, params):
    """< 0 where eq 21 must leave cruise for PD: |r_g| < r_gl or v < v_stop."""
    return min(norm(v) - params.v_stop, _distance_to_goal(p, goal) - params.r_gl)


def next_mode(mode: int, p: np.ndarray, v: np.ndarray, goal: np.ndarray, params):
    """The mode eq 21 selects from `mode` at (p, v): PD leaves for cruise
    where cruise_guard ≥ 0, cruise for PD where pd_guard ≤ 0; else `mode`.
    From PD it is also the mode eq 21 selects from scratch."""
    if mode == MODE_PD:
        return MODE_CRUISE if cruise_guard(p, v, goal, params) >= 0.0 else MODE_PD
    return MODE_PD if pd_guard(p, v, goal, params) <= 0.0 else MODE_CRUISE


def _lag_drag(speed, F_perp_sq, lag: float, mass: float):
    # a = τ|F⊥|/m, so τω = a/v; D = (m/τ) v a² / (v² + 2a²), finite for v > 0.
    a_sq = F_perp_sq * (lag / mass) ** 2
    return (mass / lag) * speed * a_sq / (speed * speed + 2.0 * a_sq)


def lag_drag(v: np.ndarray, F_perp: np.ndarray, lag: float, mass: float):
    """Repair (g): the drag D ≥ 0 [N] that eq 19 adds along −l_a while the
    vehicle turns under the force F_perp (⟂ v) that the attitude loop realises
    `lag` seconds late.

    Realised late, a force ⟂ v is no longer ⟂ to the velocity that has turned
    meanwhile: it does the work τ|F⊥|²/m per second and speeds the vehicle up
    (v turns at ω = |F⊥|/(m v)). A command F⊥ − D l_a stays ⟂ to the velocity
    τ later, v + τ(F⊥ − D l_a)/m, when D v = τ(|F⊥|² + D²)/m, i.e. to first
    order in τω: D = τ|F⊥|²/(m v). The drag used, D = m v/τ · (τω)² /
    (1 + 2(τω)²), is that to first order and smoothly bounded by m v/(2τ),
    the exact solution's value at the largest turn rate it allows (τω = 1/2).
    Zero when F⊥ = 0 and at rest."""
    v, F_perp = entries(v), entries(F_perp)
    speed = norm(v)
    if speed < TINY:
        return 0.0 * speed
    return _lag_drag(speed, dot(F_perp, F_perp), lag, mass)


def attitude_lag(params) -> float:
    """The lag τ = 2ζ/ω_n [s] with which eq 25's attitude loops (natural
    frequency ω_n, damping ζ) follow a steadily turning setpoint."""
    return 2.0 * params.attitude_damping_ratio / params.attitude_natural_frequency


def goal_terms(
    mode: int,
    p: np.ndarray,
    v: np.ndarray,
    goal: np.ndarray,
    params,
    F_o=None,
    mass=None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The goal part of eq 21 for `mode`, as (F_gc, F_v, F_pd); the inactive
    terms are zero.

    With repair (g) (`params.lag_drag`), the obstacle force F_o and the
    vehicle's `mass` given, F_v also holds `lag_drag`'s −D l_a for the
    turning force F_o + F_gc; without them (F_o None or mass None) F_v is
    eq 19 alone."""
    zero = _zero3(v)
    if mode == MODE_CRUISE:
        v = entries(v)
        speed, l_a = _heading(v)
        (p0, p1, p2), (g0, g1, g2) = entries(p), entries(goal)
        r_g = (g0 - p0, g1 - p1, g2 - p2)
        F_gc = _goal_attraction(
            v, speed, l_a, r_g, params.K_omega, params.smooth_goal_turn
        )
        F_v = _speed_control(speed, l_a, params.K_v, params.v_d)
        if params.lag_drag and F_o is not None and mass is not None and speed > TINY:
            # Repair (g): F⊥ = F_o + F_gc, the turning part of eq 21's F_n.
            F_o = entries(F_o)
            F = (F_o[0] + F_gc[0], F_o[1] + F_gc[1], F_o[2] + F_gc[2])
            along = dot(F, l_a)
            F_perp_sq = dot(F, F) - along * along
            if F_perp_sq < 0.0:  # rounding
                F_perp_sq = 0.0 * F_perp_sq
            D = _lag_drag(speed, F_perp_sq, attitude_lag(params), mass)
            F_v = (F_v[0] - D * l_a[0], F_v[1] - D * l_a[1], F_v[2] - D * l_a[2])
        return np.array(F_gc), np.array(F_v), zero
    return zero, zero, terminal_pd_field(p, v, goal, params)
