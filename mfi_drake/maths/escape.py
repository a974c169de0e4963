"""The escape rule of MFI in non-convex worlds (the default "mfi",
docs/nonconvex.md), as plain numpy functions on a fixed-size memory.

MFI's goal attraction (eq 16–18) pulls the vehicle back into a cup or a
room's far wall, where eq 12's boundary following turns it to and fro: it
stalls. The rule is a Bug algorithm's two modes of motion, after 3DBug
(Kamon, Rimon, Rivlin, ICRA 1999, "Range-sensor based navigation in three
dimensions"): motion toward the goal (MFI itself), and traversal of the
obstacle's surface until a leave condition holds; a loop round the surface
without leaving means the goal cannot be reached that way. It is realised
as MFI's own fields aimed at a moving target (a subgoal) instead of the
goal, so MFI's guarantees against contact (eq 14–15) hold throughout.

- Trap detection: the best distance to the goal so far, d_best, has not
  fallen by `progress` for `stall_time` seconds (going round the same
  surface makes no progress either). Being at the goal is progress: within
  `progress` of it (where no such gain is left to make) the goal is held,
  every phase returns to motion toward it and the clock restarts, so no
  phase flies the vehicle off a goal it holds.
- Traversal: the hit point H and d_hit = d_best are remembered; the vehicle
  circulates round the surface about a fixed axis a, as a current round
  the obstacle (the picture of MFI; Ataka et al., Front. Robot. AI 9, 2022,
  doi 10.3389/frobt.2022.834177, keep a current's direction to get round
  concave obstacles), toward a subgoal `lookahead` ahead at clearance
  r_f (`escape_steering`). The first axis is ±e_z, the sign that
  continues the vehicle's motion (it goes round horizontally the way it
  was going); then −that; then the horizontal axis ⟂ the goal direction,
  both signs (over and under).
- The ground (its height, where the world has one) is never followed, and
  on a horizontal axis a traversal whose tangent leads down into it is
  skipped where it begins ("under" a surface on the ground) and exhausted
  where it comes down to within ρ of it.
- Door: while following, the followed surface rounded at an edge (its
  closest point stays put as the vehicle moves along it: a jamb, not a
  wall's face) and another reading's closest point 2R + `GAP_MARGIN` to
  `DOOR_WIDEST` from it (a separate obstacle: the sensor reads one closest
  point an obstacle, so the far jamb of a door in a wall of boxes is its
  own reading) reveal a gap: the vehicle passes it along the line ⟂ the two
  through their middle (phase PASS: pure pursuit of a subgoal
  `PASS_AHEAD` ahead on that line), then goes toward the goal again; a gap
  not passed within `stall_time` is given up and the traversal goes on;
  the last gap passed is not passed again. (TangentBug's discontinuity
  points of the range data, Kamon, Rimon, Rivlin, IJRR 17(9), 1998, read
  from the closest points of separate obstacles.)
- Leave: |r_g| < d_hit − `leave_margin` and no seen surface's tangent plane
  hides the goal (3DBug's leaving condition, with the tangent plane at the
  closest point as the local range data).
- Loop: back within `loop_radius` of H after having been 2·loop_radius
  away, following the surface followed where the axis began (closest
  points within `loop_radius`: not the opposite wall of a corridor), the
  axis is exhausted and the next one is taken; a new trap within
  `revisit_radius` of a remembered hit point resumes at that point's next
  axis. When all four axes are exhausted the goal is declared unreachable:
  the phase is TRAPPED for good (3DBug: a loop without a leave ends the
  search).

In a fleet the memory, the subgoal, the door test and the corner brake
read the static scene's readings only: the other vehicles are moving
obstacles that MFI's own fields (eq 11–15, with the velocity relative to
each: `relative_escape_terms`) turn the vehicle round, not surfaces to
follow, corners or jambs. A lone vehicle's readings are its scene's.

The memory (`memory_size(count)` floats for a sensor of `count` readings,
70 at the default 3; a fixed layout below, the per-reading records last)
is bounded in size by construction, and in age: the progress record spans at most
`stall_time`, and only the last `HITS` hit points are kept (a ring).

How the memory steers MFI's fields (the subgoal, the corner brake, eq
16–19 redirected): `maths.escape_steering`. `maths.compiled` compiles this
module for the compiled engine: one
source, so its functions take no optional tuples, generators or
`min(key=)`, and the ground is a float (`NO_GROUND` for none) inside.

(Over 500 lines: the rule's cases above, each measured in
docs/nonconvex.md, until one escape core with typed state replaces them,
issue 50.)
"""

import math
from dataclasses import dataclass

import numpy as np

from mfi_drake.maths.layout import OBSTACLE_COUNT, POSITION, VELOCITY, readings

# Phases of the memory.
TOWARD = 0  # MFI toward the goal
FOLLOW = 1  # traversal of a surface toward a subgoal
TRAPPED = 2  # every axis exhausted: the goal cannot be reached
PASS = 3  # through a gap between two surfaces (a door) seen while following
AXES = 4  # ±e_z, ± the horizontal ⟂ the goal direction
HITS = 4  # hit points remembered (a ring)

# The memory's layout: one float vector.
PHASE, D_BEST, T_BEST = 0, 1, 2
HIT = slice(3, 6)  # H, where the current traversal began
D_HIT, AXIS, SIGN, AWAY = 6, 7, 8, 9  # AWAY: 2·loop_radius from H since
SURFACE = slice(10, 13)  # the followed surface's last closest point
SURFACE_SEEN = 13  # 1 once SURFACE holds a point
# The followed surface's closest point where the current axis's traversal
# began (inf: none seen there): a loop closes only back on that surface.
HIT_SURFACE = slice(14, 17)
LAST_P = slice(17, 20)  # p at the last step's update while following
DOOR = slice(20, 23)  # the middle of the gap being passed (PASS)
DOOR_AXIS = slice(23, 26)  # the unit direction through it
PASSED = slice(26, 29)  # the middle of the last gap passed (inf: none)
RING_NEXT = 29  # the ring's next slot
RING = RING_NEXT + 1  # HITS rows of [x, y, z, next axis]
# Every phase's record of the seen readings for the corner brake and the
# leave condition (`record_surfaces`): p, then (below) each reading's
# closest point (inf where none) and the surface's radius of curvature
# there (inf: locally a plane).
SEEN_P = slice(RING + 4 * HITS, RING + 4 * HITS + 3)
FIXED_SIZE = SEEN_P.stop  # the records that do not grow with the count
# Per reading of a sensor of c readings, after FIXED_SIZE: the followable
# readings' closest points at the last step's update while following (3c,
# inf where none: which stayed put), SEEN_POINTS (3c) and RADII (c).
PER_READING = 7


def memory_size(count: int) -> int:
    """The memory's length for a sensor of `count` readings."""
    return FIXED_SIZE + PER_READING * count


def _count(memory) -> int:
    """The readings the memory `memory` records (its length says)."""
    return (len(memory) - FIXED_SIZE) // PER_READING


def _last_points(memory):
    """LAST_POINTS of `memory`, (count, 3) a view."""
    c = _count(memory)
    return memory[FIXED_SIZE : FIXED_SIZE + 3 * c].reshape(c, 3)


def _seen_points(memory):
    """SEEN_POINTS of `memory`, (count, 3) a view."""
    c = _count(memory)
    return memory[FIXED_SIZE + 3 * c : FIXED_SIZE + 6 * c].reshape(c, 3)


def _radii(memory):
    """RADII of `memory`, (count,) a view."""
    c = _count(memory)
    return memory[FIXED_SIZE + 6 * c : FIXED_SIZE + 7 * c]


# The per-reading records at the default count (tests and tools index them).
LAST_POINTS = slice(FIXED_SIZE, FIXED_SIZE + 3 * OBSTACLE_COUNT)
SEEN_POINTS = slice(LAST_POINTS.stop, LAST_POINTS.stop + 3 * OBSTACLE_COUNT)
RADII = slice(SEEN_POINTS.stop, SEEN_POINTS.stop + OBSTACLE_COUNT)
MEMORY_SIZE = memory_size(OBSTACLE_COUNT)

E_Z = np.array([0.0, 0.0, 1.0])
NO_GROUND = -math.inf  # the ground's height where there is none
ON_GROUND = 1e-3  # m: a reading whose point lies this near the ground is the ground's
SWITCH = 0.25  # m, see followed_point
# Two surfaces whose normals are further apart than 135° are the two sides of
# a gap (a door, a corridor), which the vehicle passes along; nearer, they
# form a concave corner, where turning away from one turns toward the other.
GAP_COSINE = -math.sqrt(0.5)
# A door: the followed surface is rounded at an edge (its closest point moves
# less than EDGE_RATIO times the vehicle's motion along it; a plane's moves
# as much, a sphere's of radius ≥ 1 m at 0.7 m at least 0.6 as much) and
# another reading's closest point lies GAP_MARGIN + 2R to DOOR_WIDEST away.
EDGE_RATIO = 0.5
GAP_MARGIN = 0.3  # m, beyond 2R: the door's clearance on both sides together
DOOR_WIDEST = 2.0  # m; wider, rounding one jamb at r_f passes it (1.34 m)
# A round edge (`goal_hidden`): a radius of curvature of at least 1 cm; a
# box's corner measures 0 (to rounding), a BARN post 0.075 m.
ROUND = 0.01
PASS_AHEAD = 1.0  # m, the subgoal's lead along the line through the door
PASS_BEYOND = 1.0  # m past the door's middle: through


@dataclass
class EscapeParams:
    """The escape rule's constants (the module docstring; the subgoal's and
    the corner brake's: `escape_steering`): a scenario's `escape:` section,
    each overridable by `--set escape.NAME=VALUE`; every number must be
    finite and > 0."""

    stall_time: float = 15.0  # s without progress: trapped at a surface
    # m, the least gain in d_best that is progress; within it of the goal,
    # where no such gain is left, the goal is held (no trap, no traversal).
    progress: float = 0.5
    follow_distance: float = 0.45  # m, r_f: the clearance hugged while following
    hug: float = 1.0  # 1/m, κ: how hard the subgoal pulls toward r_f
    lookahead: float = 3.0  # m, the subgoal's distance ahead
    # m/s, eq 19's v_d while following: MFI's cruise speed; the corner brake
    # (`corner_speed`) slows it where a turn alone cannot keep it clear.
    follow_speed: float = 1.0
    leave_margin: float = 0.3  # m, leave only this much nearer than d_hit
    loop_radius: float = 1.0  # m, back this near H: a loop is closed
    revisit_radius: float = 1.5  # m, a trap this near a hit point resumes it
    corner_brake: bool = True  # eq 19's v_d limited in a concave corner
    # Eq 19's v_d limited through a door against what stands in or behind
    # it (`escape_steering.door_speed`): off by default, where it costs
    # flights (docs/nonconvex.md rule 7); on, clutter seen with more
    # readings is passed without contact.
    door_brake: bool = False
    # With depth cameras too (off: MFI flies memoryless there, `escape_off`):
    # the rule follows surfaces beside and below that no camera may see.
    cameras: bool = False


def initial_memory(
    p: np.ndarray, goal: np.ndarray, count: int = OBSTACLE_COUNT
) -> np.ndarray:
    """The memory at the start (t = 0): toward the goal, d_best = |r_g|;
    `count`: the sensor's readings."""
    memory = np.zeros(memory_size(count))
    memory[D_BEST] = _norm(goal - p)
    memory[PASSED] = np.inf
    memory[FIXED_SIZE : FIXED_SIZE + 6 * count] = np.inf  # last and seen points
    memory[SEEN_P] = p
    _radii(memory)[:] = np.inf
    memory[RING : RING + 4 * HITS] = np.tile([np.inf, np.inf, np.inf, 0.0], HITS)
    return memory


def axis(memory: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The circulation axis a of the traversal in `memory`: k = 0, 1 are
    ±e_z (horizontal circulation), 2, 3 ± the horizontal unit ⟂ the
    direction from H to the goal (vertical circulation), each times the
    traversal's sign."""
    k, sign = int(memory[AXIS]), memory[SIGN]
    if k < 2:
        return sign * (1.0 if k == 0 else -1.0) * E_Z
    side = np.cross(E_Z, goal - memory[HIT])
    size = _norm(side)
    side = side / size if size > 1e-9 else np.array([0.0, 1.0, 0.0])
    return sign * (1.0 if k == 2 else -1.0) * side


def followed_point(
    memory: np.ndarray,
    obstacle,
    p: np.ndarray,
    a: np.ndarray,
    near: float,
    ground: float | None = None,
):
    """The closest point (world frame) of the followed surface: among the
    seen readings whose direction is not within 45° of ±a (walls, not the
    ground or a ceiling, for a = ±e_z), the one whose point lies nearest the
    followed point remembered, unless the nearest is closer than `near`
    (the hugged distance of centre) or `SWITCH` nearer than that one, and
    the vehicle is not between the two (normals more than 90° apart): a
    wall ahead takes over at a concave corner, and at a doorway the jamb
    being rounded is kept, not the far one. The ground (height `ground`,
    None: none) is never followed: an endless plane cannot be gone round.
    The nearest where none is remembered; None if there is no candidate."""
    return _followed(memory, _candidates(obstacle, p, a, ground), p, near)


def _followed(memory: np.ndarray, points: list, p: np.ndarray, near: float):
    """`followed_point` among the candidates `points` (`_candidates`)."""
    if len(points) == 0:
        return None
    nearest = points[0]  # readings come nearest first
    if not memory[SURFACE_SEEN]:
        return nearest[1]
    kept = points[_kept(points, memory[SURFACE])]
    closer = nearest[0] < near or nearest[0] < kept[0] - SWITCH
    # Normals more than 90° apart put the vehicle between the two surfaces:
    # the far jamb of a door it is rounding the near one into, not a wall
    # ahead at a concave corner (a room's right angle: 90° up to rounding).
    facing = (nearest[1] - p) @ (kept[1] - p) / (nearest[0] * kept[0])
    return nearest[1] if closer and facing > -1e-9 else kept[1]


def _candidates(obstacle, p: np.ndarray, a: np.ndarray, ground) -> list:
    """(distance, closest point) of the seen readings that can be followed
    about axis a: not within 45° of ±a, not the ground; nearest first."""
    points = []
    low = _ground_height(ground) + ON_GROUND
    for r_o, seen in readings(obstacle):
        distance = _norm(r_o)
        grounded = p[2] + r_o[2] <= low
        if (
            seen > 0.5
            and distance > 1e-9
            and abs(r_o @ a) < math.sqrt(0.5) * distance
            and not grounded
        ):
            points.append((distance, p + r_o))
    return points


def _kept(points: list, surface: np.ndarray) -> int:
    """The index of the candidate (`_candidates`) whose point lies nearest
    `surface`, the first of equals."""
    best = 0
    for i in range(1, len(points)):
        if _norm(points[i][1] - surface) < _norm(points[best][1] - surface):
            best = i
    return best


def _ground_height(ground) -> float:
    """The ground's height, NO_GROUND (−∞) for None: nothing lies on it."""
    return NO_GROUND if ground is None else ground


def _norm(x: np.ndarray) -> float:
    """|x|, numpy's √(x·x) (`maths.compiled` swaps in that form: numba's
    norm differs in the last bit)."""
    return np.linalg.norm(x)


def _row_norms(x: np.ndarray) -> np.ndarray:
    """The norms of the rows of x (numpy's; `maths.compiled` swaps in
    numpy's sum: numba's norm takes no axis)."""
    return np.linalg.norm(x, axis=1)


def door(
    memory: np.ndarray,
    obstacle,
    p: np.ndarray,
    a: np.ndarray,
    collision_radius: float,
    ground: float | None = None,
):
    """(middle, unit direction through) of a gap seen while following, or
    None: the followed surface's closest point q has stayed put since the
    last step (it moved less than EDGE_RATIO times the vehicle's motion ⟂
    q − p: an edge, a jamb being rounded, not a wall's face, whose closest
    point moves with the vehicle, as in a concave corner), and so has
    another reading's closest point q' (the far jamb's edge, not the face
    of the wall a baffle stands on), 2R + GAP_MARGIN to DOOR_WIDEST from q
    (a separate obstacle: the sensor reads one closest point an obstacle),
    their middle not the last gap passed. The way through is ⟂
    q' − q, from the vehicle toward the line through the two."""
    points = _candidates(obstacle, p, a, ground)
    middle, through = _gap(memory, points, p, collision_radius)
    return (middle, through) if through.any() else None


def _gap(memory, points: list, p, collision_radius) -> tuple:
    """`door`'s (middle, unit direction through) among the candidates
    `points` (`_candidates`), `_no_gap` where there is none (one type for
    numba). The gap is measured between the two edges' rounded shapes
    (`_edge_centre`), not between their closest points: two posts' closest
    points lie up to 2ρ each further apart than their surfaces do; the way
    through is still ⟂ the closest points, through their middle (a radius
    measured across a face's corner would move a centre, never them)."""
    if not memory[SURFACE_SEEN] or len(points) < 2:
        return _no_gap()
    kept = points[_kept(points, memory[SURFACE])][1]
    rho = _edge_radius(kept, memory[SURFACE], p, memory[LAST_P])
    if not rho < math.inf:  # a face, or no motion across
        return _no_gap()
    centre = _edge_centre(kept, rho, p)
    last = _last_points(memory)
    for _, other in points:
        before = last[np.argmin(_row_norms(last - other))]
        rho_other = _edge_radius(other, before, p, memory[LAST_P])
        if not rho_other < math.inf:
            continue
        gap = float(_norm(_edge_centre(other, rho_other, p) - centre))
        gap -= rho + rho_other
        w = other - kept
        span = float(_norm(w))
        middle = (kept + other) / 2
        if (
            not 2 * collision_radius + GAP_MARGIN < gap < DOOR_WIDEST
            or _norm(middle - memory[PASSED]) < span
        ):
            continue
        c = middle - p
        through = c - (c @ w) * w / (span * span)
        size = float(_norm(through))
        if size > 1e-6:
            return middle, through / size
    return _no_gap()


def _no_gap() -> tuple:
    """`_gap`'s answer where there is no gap: a zero direction."""
    return np.zeros(3), np.zeros(3)


def _edge_radius(q: np.ndarray, before: np.ndarray, p: np.ndarray, p_before) -> float:
    """The radius of curvature ρ of the surface whose closest point q
    (`before` at the last step, p_before the vehicle's position then) has
    moved while the vehicle moved across q − p; inf for a face (locally a
    plane), nan where the vehicle did not move across. Seen from distance
    d, a round edge's closest point moves ρ/(ρ + d) times the vehicle's
    motion across (the angle swept about its centre, times ρ), so
    ρ = d μ/(1 − μ) from the measured ratio μ; a sharp edge (a jamb) is
    ρ = 0. Below EDGE_RATIO it is an edge; above, a face: a plane at the
    scale of the vehicle's distance (a sphere of radius 1 m at 0.7 m moves
    0.6 as much).

    An edge's radius is measured in the horizontal plane (`_across`): the
    closest point slides along an edge's line with the vehicle (a jamb's
    with the vehicle's climb), and the edges a traversal about ±e_z goes
    round (posts, pillars, jambs) stand upright. Where the horizontal
    motion cannot tell, or `before` does not lie on the circle the estimate
    describes (the point jumped from a face to its corner within the step),
    the edge counts as sharp: ρ = 0, the safe side of the door's gap and of
    the leave condition."""
    d = _norm(q - p)
    n = (q - p) / d
    step = p - p_before
    along = _norm(step - (step @ n) * n)
    if not along > 1e-6:
        return math.nan
    if not _norm(q - before) < EDGE_RATIO * along:
        return math.inf
    n_h = _across(q - p)
    d_h = _norm(n_h)
    if not d_h > 0.5 * d:  # read from above or below
        return 0.0
    n_h = n_h / d_h
    step_h = _across(step)
    along_h = _norm(step_h - (step_h @ n_h) * n_h)
    mu = _norm(_across(q - before)) / along_h if along_h > 1e-6 else 1.0
    if not mu < EDGE_RATIO:
        return 0.0
    rho = d_h * mu / (1.0 - mu)
    if abs(_norm(_across(before - _edge_centre(q, rho, p))) - rho) > 0.1 * rho + 1e-3:
        return 0.0
    return rho


def _across(x: np.ndarray) -> np.ndarray:
    """x's horizontal part (⟂ e_z)."""
    return np.array([x[0], x[1], 0.0])


def _edge_centre(q: np.ndarray, rho: float, p: np.ndarray) -> np.ndarray:
    """The axis of a round upright edge of radius ρ whose closest point to
    p is q, at q's height: ρ beyond q horizontally, away from p."""
    n_h = _across(q - p)
    size = _norm(n_h)
    return q + rho * n_h / size if size > 0.0 else q


def goal_hidden(
    memory: np.ndarray,
    p: np.ndarray,
    obstacle,
    r_g: np.ndarray,
    collision_radius: float,
) -> bool:
    """Whether a seen surface lies between the vehicle at p and the goal
    (r_g from p): 3DBug's leaving condition on the local range data. A
    surface read as a plane (`record_surfaces`) hides the goal beyond its
    tangent plane at the closest point, r_g·n > |r_o|; a round edge of
    measured radius ρ (a post, a pillar: ρ ≥ `ROUND`) only where the
    vehicle going straight to the goal would touch the disc of radius ρ
    about its axis (horizontally): the tangent plane of a 0.075 m post hides
    half the world, and in clutter some post's always hid the goal. A
    sharp edge (ρ < `ROUND`: a jamb, a box's corner) keeps its tangent
    plane: the face it bounds is unseen. `memory` as `record_surfaces`
    left it at p: reading i's radius is its record i."""
    radii = _radii(memory)
    way = _across(r_g)
    length = _norm(way)
    for i, (r_o, seen) in enumerate(readings(obstacle)):
        distance = _norm(r_o)
        if seen < 0.5 or distance < 1e-9:
            continue
        rho = radii[i]
        if ROUND <= rho < math.inf and length > 1e-9:
            # An upright post: the horizontal way to the goal against its axis.
            c = _across(_edge_centre(p + r_o, rho, p) - p)
            along = min(max(c @ way / length, 0.0), length)
            if _norm(c - along * way / length) < rho + collision_radius:
                return True
        elif r_g @ r_o > distance * distance:
            return True
    return False


def _start_traversal(memory, p, v, obstacle, goal, near, params, ground) -> None:
    """A trap at p: remember the hit point and pick its axis and sign."""
    ring = memory[RING : RING + 4 * HITS].reshape(HITS, 4)
    gaps = _row_norms(ring[:, :3] - p)
    slot = int(np.argmin(gaps))
    if not gaps[slot] < params.revisit_radius:
        slot = int(memory[RING_NEXT])
        memory[RING_NEXT] = (slot + 1) % HITS
        ring[slot, :3] = p
        ring[slot, 3] = 0.0
    k = int(ring[slot, 3])
    memory[HIT] = p
    memory[D_HIT] = memory[D_BEST]
    memory[SURFACE_SEEN] = 0.0
    memory[AXIS] = min(k, AXES - 1)
    memory[SIGN] = 1.0
    memory[PHASE] = FOLLOW
    # The sign that continues the vehicle's motion round the surface.
    q = followed_point(memory, obstacle, p, axis(memory, goal), near, ground)
    if q is not None:
        tangent = np.cross(axis(memory, goal), q - p)
        memory[SIGN] = -1.0 if tangent @ v < 0.0 else 1.0
    _begin_axis(memory, k, p, obstacle, goal, near, ground)


def _begin_axis(memory, k, p, obstacle, goal, near, ground) -> None:
    """Traversal of the current hit point about axis k (TRAPPED from AXES
    on), which the ring remembers as the point's axis to resume. Above a
    ground, an axis whose tangent at p points down is skipped: "under" a
    surface standing on the ground is impossible."""
    ring = memory[RING : RING + 4 * HITS].reshape(HITS, 4)
    slot = int(np.argmin(_row_norms(ring[:, :3] - memory[HIT])))
    memory[AWAY] = 0.0
    memory[HIT_SURFACE] = np.inf
    for each in range(k, AXES):
        memory[AXIS] = ring[slot, 3] = each
        q = followed_point(memory, obstacle, p, axis(memory, goal), near, ground)
        if q is None:
            return
        if not _into_ground(memory, p, q, goal, ground):
            memory[HIT_SURFACE] = q
            return
    memory[AXIS] = ring[slot, 3] = AXES
    memory[PHASE] = TRAPPED


def update_memory(
    memory: np.ndarray,
    t: float,
    p: np.ndarray,
    v: np.ndarray,
    obstacle: np.ndarray,
    goal: np.ndarray,
    collision_radius: float,
    params: EscapeParams,
    ground: float | None = None,
) -> np.ndarray:
    """The memory after one step at time t, position p, velocity v and the
    readings `obstacle`, above the ground at height `ground` (None: no
    ground; see the module docstring); a new array."""
    near = collision_radius + params.follow_distance
    memory = memory.copy()
    phase = memory[PHASE]
    if phase == TRAPPED:
        return memory
    record_surfaces(memory, p, obstacle)
    r_g = goal - p
    d = float(_norm(r_g))
    if d <= params.progress:
        # Being at the goal is progress: within `progress` of it no gain of
        # `progress` is left to make, so a stall there is the goal held, not
        # a trap, and no phase may steer away from it (by default that is
        # also where eq 21's PD zone has faded every obstacle term, r_gl/2).
        memory[PHASE], memory[D_BEST], memory[T_BEST] = TOWARD, d, t
        return memory
    if phase == TOWARD:
        if d < memory[D_BEST] - params.progress:
            memory[D_BEST], memory[T_BEST] = d, t
        elif t - memory[T_BEST] > params.stall_time:
            _start_traversal(memory, p, v, obstacle, goal, near, params, ground)
        return memory
    if phase == PASS:
        # Through the door: toward the goal again; stuck before it (no way
        # through after all): the traversal goes on.
        if (p - memory[DOOR]) @ memory[DOOR_AXIS] > PASS_BEYOND:
            memory[PHASE], memory[D_BEST], memory[T_BEST] = TOWARD, d, t
        elif t - memory[T_BEST] > params.stall_time:
            memory[PHASE], memory[LAST_P] = FOLLOW, p
        return memory
    if d < memory[D_HIT] - params.leave_margin and not goal_hidden(
        memory, p, obstacle, r_g, collision_radius
    ):
        memory[PHASE], memory[D_BEST], memory[T_BEST] = TOWARD, d, t
        return memory
    _follow(memory, t, p, obstacle, goal, collision_radius, near, params, ground)
    return memory


def _follow(memory, t, p, obstacle, goal, collision_radius, near, params, ground):
    """`update_memory` in FOLLOW, not leaving: a door seen is passed (PASS),
    else the followed surface is recorded, and a loop back to the hit
    point, or the ground in the way, exhausts the axis."""
    # The followable readings, once for the door, the record and the
    # followed point.
    candidates = _candidates(obstacle, p, axis(memory, goal), ground)
    middle, through = _gap(memory, candidates, p, collision_radius)
    memory[LAST_P] = p
    last = _last_points(memory)
    last[:] = np.inf
    for i, (_, point) in enumerate(candidates):
        last[i] = point
    if through.any():
        memory[DOOR], memory[DOOR_AXIS] = middle, through
        memory[PASSED] = middle
        memory[PHASE], memory[T_BEST] = PASS, t
        return
    q = _followed(memory, candidates, p, near)
    if q is not None:
        memory[SURFACE], memory[SURFACE_SEEN] = q, 1.0
    gone = _norm(p - memory[HIT])
    if gone > 2.0 * params.loop_radius:
        memory[AWAY] = 1.0
    looped = (
        memory[AWAY]
        and gone < params.loop_radius
        and _on_hit_surface(memory, params.loop_radius)
    )
    # Circulating in a vertical plane, the vehicle has come down to the
    # ground and the way on is through it: the axis is exhausted too.
    grounded = (
        q is not None
        and _into_ground(memory, p, q, goal, ground)
        and p[2] - _ground_height(ground) < near
    )
    if looped or grounded:
        _begin_axis(memory, int(memory[AXIS]) + 1, p, obstacle, goal, near, ground)


def record_surfaces(memory: np.ndarray, p: np.ndarray, obstacle) -> None:
    """Remember p and each seen reading's closest point q, and the radius
    of curvature of the surface there (`_edge_radius`: inf for a plane at
    the scale of the vehicle's distance). The same surface is the
    remembered point within |Δp| of q (projection onto a convex shape is
    non-expansive); a surface seen anew is taken for a plane (the corner
    brake's and the leave condition's safe side), and one without motion
    across it keeps its radius, until the motion tells."""
    last = _seen_points(memory).copy()
    old = _radii(memory).copy()
    moved = _norm(p - memory[SEEN_P])
    points = np.full((len(last), 3), np.inf)
    radii = np.full(len(last), np.inf)
    for i, (r_o, seen) in enumerate(readings(obstacle)):
        if seen < 0.5 or _norm(r_o) < 1e-9:
            continue
        q = p + r_o
        points[i] = q
        gaps = _row_norms(last - q)
        j = int(np.argmin(gaps))
        if not gaps[j] <= moved + 1e-9:
            continue
        rho = _edge_radius(q, last[j], p, memory[SEEN_P])
        radii[i] = old[j] if math.isnan(rho) else rho
    memory[SEEN_P] = p
    _seen_points(memory)[:] = points
    _radii(memory)[:] = radii


def plane_flags(
    memory: np.ndarray, p: np.ndarray, obstacle, collision_radius: float, r_b: float
) -> np.ndarray:
    """For each seen reading of `obstacle` (vehicle at p) within eq 15's r_b
    (those the corner brake reads), whether its surface is locally a plane
    by `record_surfaces`: that of the remembered point nearest its closest
    point (1: a plane, where none is remembered, and for the readings not
    asked about)."""
    last = _seen_points(memory)
    flags = np.ones(len(last))
    for i, (r_o, seen) in enumerate(readings(obstacle)):
        if seen < 0.5 or not _norm(r_o) - collision_radius < r_b:
            continue
        gaps = _row_norms(last - (p + r_o))
        j = int(np.argmin(gaps))
        if np.isfinite(gaps[j]):
            flags[i] = 1.0 if _radii(memory)[j] == np.inf else 0.0
    return flags


def _into_ground(memory, p, q, goal, ground) -> bool:
    """Whether the traversal's tangent a × n at p, the followed point q,
    leads down above a ground: on a horizontal axis (k ≥ 2: circulation in a
    vertical plane) that is "under", impossible for a surface standing on
    the ground, and the ground itself cannot be gone round."""
    if _ground_height(ground) == NO_GROUND or memory[AXIS] < 2:
        return False
    return bool(np.cross(axis(memory, goal), q - p)[2] < 0.0)


def _on_hit_surface(memory: np.ndarray, radius: float) -> bool:
    """Whether the followed surface is the one followed where the axis's
    traversal began (its closest point within `radius` of that one's;
    true where either is unknown): back near H on the opposite wall of a
    corridor is not a loop round the surface (Bug's loop returns to H along
    the boundary it left by)."""
    start = memory[HIT_SURFACE]
    if not memory[SURFACE_SEEN] or not np.isfinite(start).all():
        return True
    return bool(_norm(memory[SURFACE] - start) < radius)


def fleet_memories(
    memories: np.ndarray,
    t: float,
    states: np.ndarray,
    scene: np.ndarray,
    goals: np.ndarray,
    collision_radius: float,
    params: EscapeParams,
    ground: float,
) -> np.ndarray:
    """Every vehicle's `update_memory` at time t (states (N, 12), its
    static scene's readings scene (N, 4 count), goals (N, 3)): each memory
    (row of `memories`, (N, memory_size(count))) reads its own scene only, not
    the other vehicles. A new array; one compiled call for a fleet."""
    out = np.empty_like(memories)
    for k in range(len(states)):
        x = states[k]
        out[k] = update_memory(
            memories[k],
            t,
            x[POSITION],
            x[VELOCITY],
            scene[k],
            goals[k],
            collision_radius,
            params,
            ground,
        )
    return out
