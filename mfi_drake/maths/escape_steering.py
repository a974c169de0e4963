"""How the escape rule's memory (`maths.escape`) steers MFI's fields: the
subgoal ĝ (`subgoal`), eq 19's setpoint with the corner brake
(`corner_speed`, `corner_rate`) and the redirection of eq 16–18 toward ĝ
(`redirected`), for a lone vehicle (`escape_terms`) and in a fleet
(`relative_escape_terms`).

- Subgoal while following about axis a: `lookahead` ahead along
  u = s + κ ((p_g − p)·â) â, where n points to the followed surface's
  closest point (`escape.followed_point`) at centre distance d, t = a × n /
  |a × n|, ρ = R + r_f, and s = cos β n + sin β t with sin β = ρ/d outside
  the circle of radius ρ round that point (the tangent to it: an edge is
  rounded at r_f), s = t + κ (d − ρ) n inside it; the plane ⟂ a through
  the goal (the goal's height for ±e_z) is hugged, its pull clipped at 1.
  Through a door (PASS): pure pursuit of a point PASS_AHEAD ahead on the
  line through its middle.
- Corner brake: in a concave corner eq 19's setpoint keeps the closing
  speed toward each surface below c·r (`corner_speed`, `corner_rate`);
  through a door (PASS), with `door_brake`, toward what stands in or
  behind it (`door_speed`).

`systems.escape.EscapeNavigator` calls them;
so does the compiled engine's chain (`maths.fleet`, compiled by
`maths.compiled` from this source: the same rules as `maths.escape`'s).
"""

import math

import numpy as np

from mfi_drake.maths.escape import (
    DOOR,
    DOOR_AXIS,
    FOLLOW,
    GAP_COSINE,
    GAP_MARGIN,
    PASS,
    PASS_AHEAD,
    PHASE,
    SURFACE,
    SURFACE_SEEN,
    EscapeParams,
    _norm,
    axis,
    followed_point,
    plane_flags,
)
from mfi_drake.maths.fields import (
    goal_attraction_field,
    speed_control_field,
    superposed,
)
from mfi_drake.maths.layout import POSITION, VELOCITY, readings
from mfi_drake.maths.motion import relative_field

# Two seen planes whose normals are at most ~100° apart meet in a corner
# (a room's walls, a wall and the floor: 90°); two surfaces up to GAP_COSINE
# apart only where the vehicle cannot pass between them (`corner_speed`).
CORNER_COSINE = -0.17


def corner_rate(k: float, v_d: float, r_b: float) -> float:
    """The gain c [1/s] of `corner_speed`'s closing-speed setpoint c·r: the
    largest for which eq 19 alone stops a vehicle that enters the corner's
    range r_b closing at v_d before it reaches the surface (k = K_v/m).

    With eq 19 as the only brake the closing speed s = v·n obeys
    ṡ = −k (s − c r), ṙ = −s: r̈ + k ṙ + k c r = 0, roots λ = (−k ± √(k² −
    4kc))/2. From r(0) = r_b, ṙ(0) = −v_d, r stays > 0 exactly when
    v_d ≤ |λ_fast| r_b (c ≤ k/4, real roots), so c = (k² − (2 v_d/r_b −
    k)²)/(4k), k/4 (critically damped) where that exceeds k/4, 0 where no
    c can (v_d > k r_b: the full brake stops it within v_d/k only)."""
    excess = 2.0 * v_d / r_b - k
    if excess <= 0.0:
        return k / 4.0
    return max(0.0, (k * k - excess * excess) / (4.0 * k))


def corner_speed(
    obstacle,
    v: np.ndarray,
    collision_radius: float,
    r_b: float,
    rate: float,
    planes: np.ndarray,
) -> float:
    """The speed setpoint of eq 19 in a concave corner (math.inf where no
    limit applies): |v| ≤ rate · r / (l_a·n) for each surface the vehicle
    approaches (l_a·n > 0) at clearance r, so that its closing speed
    follows the setpoint rate · r (`corner_rate`).

    MFI's obstacle terms (eq 12, 14) are ⟂ v: they turn, they do not brake.
    Against one surface a turn of at most 90° leaves it, but in a concave
    corner (two or more seen surfaces within eq 15's range r_b, their
    normals at most `CORNER_COSINE` apart and both locally planes, flag
    `planes` (`escape.plane_flags`: a reading's), or not opposed
    (`GAP_COSINE`) with closest points less than 2R + `GAP_MARGIN` apart
    while the vehicle closes on both) every tangent of one surface leads
    into another, and in the corner of two walls and a floor none is left:
    the vehicle must stop and turn back, and eq 19 is the only brake. Two
    rocks of a random field seen 95° apart leave a gap the vehicle passes,
    and one groove it flies past is no corner: braking there lengthened
    convex paths (docs/nonconvex.md)."""
    seen = []
    flat = []
    for i, (r_o, s) in enumerate(readings(obstacle)):
        if s > 0.5 and _norm(r_o) - collision_radius < r_b:
            seen.append(r_o)
            flat.append(planes[i] > 0.5)
    normals = [r_o / _norm(r_o) for r_o in seen]
    passable = 2.0 * collision_radius + GAP_MARGIN
    corner = False
    for i in range(len(normals)):
        for j in range(i):
            cosine = normals[i] @ normals[j]
            corner = corner or (
                cosine > CORNER_COSINE
                and flat[i]
                and flat[j]
                or cosine > GAP_COSINE
                and _norm(seen[i] - seen[j]) < passable
                and v @ normals[i] > 0.0
                and v @ normals[j] > 0.0
            )
    if not corner:
        return math.inf
    return _closing_limit(seen, v, collision_radius, rate)


def _closing_limit(seen: list, v: np.ndarray, collision_radius: float, rate: float):
    """|v| ≤ rate · r / (l_a·n) over the surfaces `seen` (each r_o) the
    vehicle closes on (l_a·n > 0) at clearance r (math.inf: none)."""
    speed = float(_norm(v))
    limit = math.inf
    if speed < 1e-9:
        return limit
    for r_o in seen:
        closing = (v @ (r_o / _norm(r_o))) / speed  # l_a·n
        if closing > 0.0:
            r = max(0.0, float(_norm(r_o)) - collision_radius)
            limit = min(limit, rate * r / closing)
    return limit


def door_speed(
    memory: np.ndarray,
    obstacle,
    p: np.ndarray,
    v: np.ndarray,
    collision_radius: float,
    r_b: float,
    rate: float,
) -> float:
    """The speed setpoint of eq 19 through a door (PASS): `corner_speed`'s
    closing-speed limit against the surfaces within r_b that stand in or
    behind the gap: their closest point more than R past the door's line
    along the way through, or within R of it and less than R +
    GAP_MARGIN/2 beside its middle. The pursuit pulls the vehicle on into
    them (in clutter, more posts behind the gap), where eq 14–15 only turn
    it; the door's sides, braked against, slowed every door to a crawl,
    and the surfaces on the near side (the floor, the wall above a door)
    are MFI's as before PASS."""
    along = memory[DOOR_AXIS]
    side = collision_radius + 0.5 * GAP_MARGIN
    seen = []
    for r_o, s in readings(obstacle):
        if not (s > 0.5 and _norm(r_o) - collision_radius < r_b):
            continue
        w = p + r_o - memory[DOOR]
        depth = float(w @ along)
        if depth < -collision_radius or (
            depth < collision_radius and _norm(w - depth * along) >= side
        ):
            continue
        seen.append(r_o)
    return _closing_limit(seen, v, collision_radius, rate)


def subgoal(
    memory: np.ndarray,
    p: np.ndarray,
    obstacle: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    params: EscapeParams,
    ground: float | None = None,
) -> np.ndarray:
    """The point MFI steers to: the goal, or while following, `lookahead`
    ahead along u = s + κ ((p_g − p)·â) â (see the module docstring)."""
    return _aim(memory, p, obstacle, goal, collision_radius, params, ground)[0]


def _aim(memory, p, obstacle, goal, collision_radius, params, ground) -> tuple:
    """(`subgoal`, whether it is not the goal itself)."""
    if memory[PHASE] == PASS:
        # Along the line through the door's middle, PASS_AHEAD ahead of the
        # vehicle's foot on it (pure pursuit: the offset from the line
        # decays over about PASS_AHEAD of travel).
        along = memory[DOOR_AXIS]
        s = max(0.0, float((p - memory[DOOR]) @ along))
        return memory[DOOR] + (s + PASS_AHEAD) * along, True
    if memory[PHASE] != FOLLOW:
        return goal, False
    a = axis(memory, goal)
    near = collision_radius + params.follow_distance
    q = followed_point(memory, obstacle, p, a, near, ground)
    if q is None:
        if not memory[SURFACE_SEEN]:
            return goal, False
        q = memory[SURFACE]
    r_o = q - p
    distance = float(_norm(r_o))
    n = r_o / distance
    t = np.cross(a, n)
    size = _norm(t)
    if size < 1e-6:
        return goal, False
    if distance > near:
        # Outside the circle of radius R + r_f round the followed point:
        # along the tangent from p to that circle, angle asin(near/|r_o|)
        # off n, so that an edge (a door's jamb) is rounded at r_f, not
        # cut wide as a fixed pull lagging behind the turning n would.
        beta = math.asin(near / distance)
        surface = math.cos(beta) * n + math.sin(beta) * t / size
    else:
        pull = max(-1.0, params.hug * (distance - near))
        surface = t / size + pull * n
    # The plane ⟂ a through the goal is hugged as the surface is, with the
    # same κ: circulating about ±e_z the vehicle keeps to the goal's height;
    # about a horizontal axis, to the vertical plane through H and the goal
    # (Bug algorithms' plane through the goal). Off it, a lintel or a ceiling
    # can stand in for the wall it follows and hide a door.
    unit = a / _norm(a)
    level = max(-1.0, min(1.0, params.hug * ((goal - p) @ unit)))
    u = surface + level * unit
    return p + params.lookahead * u / _norm(u), True


def steering(
    memory: np.ndarray,
    p: np.ndarray,
    v: np.ndarray,
    scene: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    navigator,
    rule: EscapeParams,
    rate: float,
    ground: float | None = None,
    cruise: bool = True,
) -> tuple:
    """(subgoal ĝ, whether eq 16–18 are redirected to it, eq 19's speed
    setpoint) from the memory and the static scene's readings `scene` (a
    fleet's other vehicles are not in them: `escape_terms`): v_d at the
    follow speed while ĝ is not the goal, at most `corner_speed` (gain
    `rate`, `corner_rate`) in a concave corner, `door_speed` in PASS with
    `door_brake`. Only while
    eq 21 cruises (`cruise`): in its PD mode (eq 20) there is no eq 16–19
    to redirect or brake, and the difference terms of `redirected` would
    act alone (a goal in a corner: held 0.5 m short of it)."""
    target, steered = _aim(memory, p, scene, goal, collision_radius, rule, ground)
    v_d = navigator.v_d
    if not cruise:
        return target, False, v_d
    if steered:
        v_d = rule.follow_speed
    if memory[PHASE] == PASS:
        # Through a door the jambs are the sides of the gap flown through,
        # not a corner ahead: eq 14–15 guard each, as MFI's do in any gap.
        if rule.door_brake:
            r_b = navigator.r_b
            v_d = min(v_d, door_speed(memory, scene, p, v, collision_radius, r_b, rate))
    elif rule.corner_brake:
        planes = plane_flags(memory, p, scene, collision_radius, navigator.r_b)
        corner = corner_speed(scene, v, collision_radius, navigator.r_b, rate, planes)
        v_d = min(v_d, corner)
    return target, steered, v_d


def redirected(
    B: np.ndarray,
    v: np.ndarray,
    target: np.ndarray,
    goal: np.ndarray,
    p: np.ndarray,
    steered: bool,
    v_d: float,
    navigator,
) -> np.ndarray:
    """B with the rule's changes to eq 19 and 16–18 (`steering`'s): F_v at
    the setpoint v_d instead of MFI's, F_v(v_d) − F_v(MFI's v_d) added, and
    while steered the redirection F_gc(ĝ) − F_gc(g)."""
    if v_d < navigator.v_d:
        # Eq 19 at the lower speed setpoint instead of v_d.
        B = (
            B
            + speed_control_field(v, navigator.K_v, v_d)
            - speed_control_field(v, navigator.K_v, navigator.v_d)
        )
    if steered:
        smooth, K = navigator.smooth_goal_turn, navigator.K_omega
        B = (
            B
            + goal_attraction_field(v, target - p, K, smooth)
            - goal_attraction_field(v, goal - p, K, smooth)
        )
    return B


def escape_terms(
    field,
    memory: np.ndarray,
    p: np.ndarray,
    v: np.ndarray,
    scene: np.ndarray,
    obstacle: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    navigator,
    rule: EscapeParams,
    rate: float,
    ground: float | None = None,
    cruise: bool = True,
) -> tuple:
    """(A, B, subgoal ĝ): MFI's obstacle terms (`superposed` of `field`,
    MFI's `obstacle_field`, of parameters `navigator`) over every reading
    `obstacle` aimed at ĝ, B `redirected` (systems.escape). The memory's
    subgoal and the corner brake read the static scene `scene` only
    (`steering`): in a fleet the other vehicles, moving, are eq 11–15's to
    turn the vehicle round, not surfaces to follow, corners or door jambs.
    A lone vehicle passes its readings as both. `cruise`: eq 21's mode is
    cruise (`steering`)."""
    target, steered, v_d = steering(
        memory,
        p,
        v,
        scene,
        goal,
        collision_radius,
        navigator,
        rule,
        rate,
        ground,
        cruise,
    )
    A, B = superposed(field, v, obstacle, target - p, collision_radius, navigator)
    return A, redirected(B, v, target, goal, p, steered, v_d, navigator), target


def relative_escape_terms(
    field,
    memory: np.ndarray,
    x: np.ndarray,
    scene: np.ndarray,
    obstacle: np.ndarray,
    u: np.ndarray,
    turns: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    navigator,
    rule: EscapeParams,
    rate: float,
    ground: float | None,
    own_pace: bool,
    blend_speed: float,
    cruise: bool = True,
) -> tuple:
    """(F_o, [A, B], ĝ) of `escape_terms` in a fleet: the field over every
    reading `obstacle` with the velocity relative to each (u, `turns`,
    own_pace, blend_speed: `motion.relative_field`'s), aimed at the
    subgoal of the memory, which with the corner brake reads the static
    scene `scene` only (`steering`, in eq 21's cruise mode `cruise`); F_o
    and B `redirected`."""
    p, v = x[POSITION], x[VELOCITY]
    target, steered, v_d = steering(
        memory,
        p,
        v,
        scene,
        goal,
        collision_radius,
        navigator,
        rule,
        rate,
        ground,
        cruise,
    )
    F_o, terms = relative_field(
        field,
        x,
        obstacle,
        u,
        turns,
        target,
        collision_radius,
        navigator,
        own_pace,
        blend_speed,
    )
    F_o = redirected(F_o, v, target, goal, p, steered, v_d, navigator)
    B = redirected(terms[3:6], v, target, goal, p, steered, v_d, navigator)
    return F_o, np.concatenate((terms[0:3], B)), target
