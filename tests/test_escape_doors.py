"""The escape rule's door detector and its passage (maths.escape.door,
phase PASS; docs/nonconvex.md, "The escape rule", rule 7)."""

import dataclasses

import numpy as np
import pytest

from mfi_drake.config import scenario as sc
from mfi_drake.config.dynamic import Ground
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import escape, escape_steering
from mfi_drake.maths.layout import obstacle_signal
from mfi_drake.world.nonconvex import room

RULE = escape.EscapeParams()
RADIUS = VEHICLES["drake_default"].collision_radius
GOAL = np.array([0.5, 5.0, 1.5])  # beyond a wall along y = 0
P = np.array([0.0, -0.7, 1.5])  # 0.7 m before the near jamb's edge (the origin)
STEP = np.array([0.05, 0.0, 0.0])  # the last step: along the wall, +x


def following(surface_moved=(0.0, 0.0, 0.0), width=1.0):
    """The memory of a vehicle following the near jamb about +e_z whose
    closest point was `surface_moved` from the origin at the last step, the
    far jamb's `width` along +x, where it is now."""
    memory = escape.initial_memory(P - STEP, GOAL)
    memory[escape.PHASE] = escape.FOLLOW
    memory[escape.D_HIT] = 0.1  # never leave
    memory[escape.SURFACE] = np.array([0.0, 0.0, 1.5]) + surface_moved
    memory[escape.SURFACE_SEEN] = 1.0
    memory[escape.LAST_P] = P - STEP
    last = [[0.0, 0.0, 1.5], [width, 0.0, 1.5], [np.inf] * 3]
    memory[escape.LAST_POINTS] = np.ravel(last)
    return memory


def jambs(width):
    """The readings at P: the near jamb's edge at the origin (height 1.5),
    the far jamb's `width` along +x."""
    near = np.array([0.0, 0.0, 1.5]) - P
    return obstacle_signal([near, near + [width, 0.0, 0.0]])


@pytest.mark.parametrize("width", [1.0, 1.1, 1.6])
def test_a_door_by_hand(width):
    """An edge rounded (its closest point stayed put while the vehicle moved
    0.05 m along the wall) and the far jamb `width` away: a door, its middle
    halfway along, the way through ⟂ the wall (+y); the memory passes it,
    its subgoal on the line through the middle, PASS_AHEAD past the wall."""
    found = escape.door(following(width=width), jambs(width), P, escape.E_Z, RADIUS)
    middle = np.array([width / 2, 0.0, 1.5])
    assert found[0] == pytest.approx(middle)
    assert found[1] == pytest.approx([0.0, 1.0, 0.0])
    memory = escape.update_memory(
        following(width=width), 20.0, P, STEP / 0.05, jambs(width), GOAL, RADIUS, RULE
    )
    assert memory[escape.PHASE] == escape.PASS
    target = escape_steering.subgoal(memory, P, jambs(width), GOAL, RADIUS, RULE)
    assert target == pytest.approx(middle + [0.0, escape.PASS_AHEAD, 0.0])
    # Through: PASS_BEYOND past the middle, toward the goal again.
    beyond = middle + [0.0, escape.PASS_BEYOND + 0.01, 0.0]
    after = escape.update_memory(
        memory, 21.0, beyond, STEP, jambs(9), GOAL, RADIUS, RULE
    )
    assert after[escape.PHASE] == escape.TOWARD
    # The door passed is not passed again.
    assert escape.door(after, jambs(width), P, escape.E_Z, RADIUS) is None


def test_through_a_door_only_what_stands_in_the_way_brakes():
    """`door_brake`'s limit (`door_speed`). Hand case, PASS through a 1 m
    door (jambs at x = 0 and 1 on y = 0, the way through +y), the vehicle
    in the door's middle flying +y at 1 m/s: the jambs beside it are the
    door's sides and do not brake (no limit); a post 0.3 m ahead, its
    closest point on the line, limits the speed to rate · r / (l_a·n) =
    rate · (0.3 − R) / 1; the same post approached at 60° off the
    velocity, to rate · r / cos 60°."""
    memory = following()
    memory[escape.PHASE] = escape.PASS
    memory[escape.DOOR] = [0.5, 0.0, 1.5]
    memory[escape.DOOR_AXIS] = [0.0, 1.0, 0.0]
    p = np.array([0.5, 0.0, 1.5])
    v = np.array([0.0, 1.0, 0.0])
    sides = [np.array([-0.5, 0.0, 0.0]), np.array([0.5, 0.0, 0.0])]
    rate, r_b = 0.25, 0.6

    def limit(*points):
        seen = obstacle_signal(list(points))
        return escape_steering.door_speed(memory, seen, p, v, RADIUS, r_b, rate)

    assert limit(*sides) == np.inf
    ahead = np.array([0.0, 0.3, 0.0])
    assert limit(*sides, ahead) == pytest.approx(rate * (0.3 - RADIUS))
    aside = 0.3 * np.array([np.sin(np.pi / 3), np.cos(np.pi / 3), 0.0])
    assert limit(aside) == pytest.approx(rate * (0.3 - RADIUS) / 0.5)
    # Beyond r_b of clearance nothing brakes.
    assert limit(np.array([0.0, r_b + RADIUS + 0.01, 0.0])) == np.inf
    # eq 19's setpoint in PASS: the follow speed, the limit with the switch.
    navigator = NavigatorParams()
    seen = obstacle_signal([*sides, ahead])
    for brake, v_d in ((False, RULE.follow_speed), (True, rate * (0.3 - RADIUS))):
        rule = dataclasses.replace(RULE, door_brake=brake)
        steer = escape_steering.steering(
            memory, p, v, seen, GOAL, RADIUS, navigator, rule, rate
        )
        assert steer[2] == pytest.approx(v_d)


def test_no_door_at_a_face_a_narrow_gap_or_a_corner():
    """A face (its closest point moved with the vehicle), a gap narrower
    than 2R + GAP_MARGIN, a far reading that is a face, and a concave
    corner (two faces' feet 0.95 m apart, what a 1 m door also looks like
    in one reading): no door."""
    assert escape.door(following(STEP), jambs(1.0), P, escape.E_Z, RADIUS) is None
    narrow = 2 * RADIUS + escape.GAP_MARGIN - 0.01
    memory = following(width=narrow)
    assert escape.door(memory, jambs(narrow), P, escape.E_Z, RADIUS) is None
    # The far reading a face (moved with the vehicle): a baffle's root wall.
    memory = following()
    memory[escape.LAST_POINTS][3] -= STEP[0]
    assert escape.door(memory, jambs(1.0), P, escape.E_Z, RADIUS) is None
    corner = obstacle_signal([np.array([0.0, 0.7, 0.0]), np.array([0.67, 0.0, 0.0])])
    memory = following(STEP)
    memory[escape.SURFACE] = P + [-0.05, 0.7, 0.0]  # the foot on the wall at +y
    assert escape.door(memory, corner, P, escape.E_Z, RADIUS) is None


POST = 0.075  # m, a BARN post's radius


def post_point(centre, p):
    """The closest point to p of a vertical post (a circle in the plane
    z = 1.5 of radius POST about `centre`)."""
    n = (p - centre) / np.linalg.norm(p - centre)
    return centre + POST * n


def between_posts(spacing):
    """A vehicle at P following post A (axis at the origin) along +x, post
    B's axis `spacing` further along +x: the memory from the last step
    (P − STEP) and the readings at P."""
    a, b = np.array([0.0, 0.0, 1.5]), np.array([spacing, 0.0, 1.5])
    before = P - STEP
    memory = escape.initial_memory(before, GOAL)
    memory[escape.PHASE] = escape.FOLLOW
    memory[escape.D_HIT] = 0.1  # never leave
    memory[escape.SURFACE] = post_point(a, before)
    memory[escape.SURFACE_SEEN] = 1.0
    memory[escape.LAST_P] = before
    last = [post_point(a, before), post_point(b, before), [np.inf] * 3]
    memory[escape.LAST_POINTS] = np.ravel(last)
    seen = obstacle_signal([post_point(a, P) - P, post_point(b, P) - P])
    return memory, seen


def test_a_posts_radius_from_its_closest_points_motion():
    """A round edge's closest point moves ρ/(ρ + d) times the vehicle's
    motion across: `_edge_radius` recovers the post's 0.075 m from one
    0.05 m step (to the step's second order), and a sharp jamb's 0."""
    a = np.array([0.0, 0.0, 1.5])
    rho = escape._edge_radius(post_point(a, P), post_point(a, P - STEP), P, P - STEP)
    assert rho == pytest.approx(POST, rel=0.01)
    assert escape._edge_radius(a, a, P, P - STEP) == 0.0
    # A face (its closest point moved with the vehicle): a plane; no motion
    # across: unknown.
    assert escape._edge_radius(a, a - STEP, P, P - STEP) == np.inf
    assert np.isnan(escape._edge_radius(a, a, P, P))


def test_a_post_hides_the_goal_only_on_the_way_to_it():
    """Leaving (3DBug's condition): a post of measured radius 0.075 m ahead
    and 0.4 m beside the line to the goal hides nothing (its tangent plane
    would hide the goal: the clutter failure), one 0.2 m beside it does
    (0.075 + R = 0.3 m), and a wall's face, read as a plane, hides the
    goal beyond its tangent plane."""
    goal = P + [0.0, 4.0, 0.0]
    for offset, hidden in ((0.4, False), (0.2, True)):
        centre = P + [offset, 1.0, 0.0]
        before = P - STEP
        memory = escape.initial_memory(before, goal)
        seen_before = obstacle_signal([post_point(centre, before) - before])
        memory = escape.update_memory(
            memory, 0.0, before, STEP, seen_before, goal, RADIUS, RULE
        )
        seen = obstacle_signal([post_point(centre, P) - P])
        memory = escape.update_memory(memory, 0.01, P, STEP, seen, goal, RADIUS, RULE)
        assert memory[escape.RADII][0] == pytest.approx(POST, rel=0.05)
        assert escape.goal_hidden(memory, P, seen, goal - P, RADIUS) == hidden
        # Read as a plane (seen anew), the post's tangent plane hides the goal.
        fresh = escape.initial_memory(P, goal)
        assert escape.goal_hidden(fresh, P, seen, goal - P, RADIUS)


@pytest.mark.parametrize(("spacing", "door"), [(0.86, False), (1.0, True)])
def test_the_gap_between_two_posts_is_measured_between_their_surfaces(spacing, door):
    """Two posts whose closest points seen from the side lie more than
    2R + GAP_MARGIN (0.75 m) apart, their surfaces 0.71 m apart: no door
    (measured between the closest points, 0.80 m, it was one, and the
    vehicle pressed into it in BARN). 0.85 m apart: a door, the way through
    ⟂ the closest points, through their middle (about +y)."""
    memory, seen = between_posts(spacing)
    closest = np.linalg.norm(seen[4:7] - seen[0:3])
    assert closest > 2 * RADIUS + escape.GAP_MARGIN
    found = escape.door(memory, seen, P, escape.E_Z, RADIUS)
    if not door:
        assert found is None
    else:
        near, far = P + seen[0:3], P + seen[4:7]
        assert found[0] == pytest.approx((near + far) / 2)
        assert found[1] @ (far - near) == pytest.approx(0.0, abs=1e-12)
        assert found[1][1] > 0.99


# (door width [m], the room's yaw [deg]): doors narrower than 2 (R + r_f) =
# 1.34 m, met side-on. With the detector off (DOOR_WIDEST = 0) none of the
# three reaches the goal in the 40 s (6.3, 0.17 and 3.9 m from it).
DOORS = [(1.0, 0.0), (1.1, 30.0), (1.1, 120.0)]


@pytest.mark.parametrize(("width", "yaw_deg"), DOORS)
def test_mfi_nc_passes_a_narrow_door_met_side_on(width, yaw_deg):
    """From inside a room, the rule follows the wall the goal lies beyond,
    rounds the corner and meets the door side-on: it detects the door and
    passes it, reaching the goal without contact within 40 s."""
    world = side_door_room(width, yaw_deg)
    metrics = simulate(world, "mfi", until_settled=True).metrics
    assert metrics["outcome"] == "success", metrics["final_error"]
    assert metrics["min_clearance"] > 0.0


def side_door_room(width: float, yaw_deg: float) -> sc.Scenario:
    """The start inside a 4 × 4 × 3 m room on the ground, the goal 3 m
    outside its +x wall; the one door, `width` wide and 2.2 m high, in the
    +y wall near the +x corner: MFI stalls at the +x wall, and the rule,
    following round it, meets the door side-on. Yawed by `yaw_deg` about
    the start."""
    goal = np.append(_turn(yaw_deg, (5.0, 0.0)), 1.5)
    return sc.Scenario(
        name=f"side_door_{width}_{yaw_deg}",
        start=[0.0, 0.0, 1.5],
        goal=goal.tolist(),
        duration=40.0,
        obstacles=room((0.0, 0.0), 4.0, 4.0, 3.0, yaw_deg, 1, 0.1, width, 2.2),
        ground=Ground(height=0.0),
        escape=escape.EscapeParams(stall_time=5.0),
    )


def _turn(yaw_deg: float, xy) -> np.ndarray:
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    return np.array([c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]])
