"""The repairs of MFI's field (NavigatorParams (a)–(g)), each against the
paper's literal form on a hand-built configuration, and the symmetric
two-sphere layout that made the paper's form chatter."""

import dataclasses
import os

import numpy as np
import pytest

from mfi_drake import load_scenario, simulate
from mfi_drake.config.parameters import NavigatorParams, paper_form
from mfi_drake.config.scenario import Obstacle, Scenario, Sphere
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.maths import fields
from mfi_drake.maths.layout import obstacle_signal
from mfi_drake.systems.navigation import GoalAttractionSelector

from .conftest import SCENARIOS

R = VEHICLES["drake_default"].collision_radius
# The cases below were measured with the gains before tuning (r_l = 1.5 m).
REPAIRED = NavigatorParams(c=4.0, r_l=1.5, c_perp=0.2, r_b=0.6, K_omega=1.5)
PAPER = paper_form(REPAIRED)
EX, EY, EZ = np.eye(3)


def only(**repairs) -> NavigatorParams:
    """The paper's form with the named repairs on."""
    return dataclasses.replace(PAPER, **repairs)


def test_a_boundary_following_acts_only_on_obstacles_in_the_way():
    v = np.array([1.0, -0.3, 0.0])  # receding from an obstacle on its left
    r_o = (0.5 + R) * EY
    params = only(follow_blocking_only=True)
    goal_ahead = 10.0 * EX
    F_paper, _ = fields.obstacle_field(v, r_o, 1.0, goal_ahead, R, PAPER)
    F, _ = fields.obstacle_field(v, r_o, 1.0, goal_ahead, R, params)
    assert np.linalg.norm(F_paper) > 0.5 and np.allclose(F, 0.0)  # pulled back
    # The same obstacle between the vehicle and the goal: followed as before.
    goal_behind = 10.0 * EY + 2.0 * EX
    F_paper, _ = fields.obstacle_field(v, r_o, 1.0, goal_behind, R, PAPER)
    F, _ = fields.obstacle_field(v, r_o, 1.0, goal_behind, R, params)
    np.testing.assert_allclose(F, F_paper)
    # Approaching: unchanged.
    v_in = np.array([1.0, 0.3, 0.0])
    np.testing.assert_allclose(
        fields.obstacle_field(v_in, r_o, 1.0, goal_ahead, R, params)[0],
        fields.obstacle_field(v_in, r_o, 1.0, goal_ahead, R, PAPER)[0],
    )


def test_b_the_head_on_side_is_continuous_in_the_heading():
    n = EX
    goal = 10.0 * EX  # straight behind the obstacle: no goal side
    currents = {}
    for name, continuous in (("paper", False), ("repaired", True)):
        currents[name] = [
            fields.artificial_current(
                (EX + s * 1e-9 * EY) / np.linalg.norm(EX + s * 1e-9 * EY),
                n,
                goal,
                REPAIRED.tangent_blend,
                continuous,
            )
            for s in (-1.0, 1.0)
        ]
    paper, repaired = currents["paper"], currents["repaired"]
    # The paper's side flips with a 2e-9 change of heading; the repair's does not.
    assert np.linalg.norm(paper[0] - paper[1]) == pytest.approx(
        2 * REPAIRED.tangent_blend, rel=1e-6
    )
    # Continuous: Lipschitz, with a slope of blend / (blend / 10) = 10.
    assert np.linalg.norm(repaired[0] - repaired[1]) < 20 * 2e-9
    # Away from exact head-on both go round the side the vehicle heads for.
    l_a = (EX + 0.05 * EY) / np.linalg.norm(EX + 0.05 * EY)
    for continuous in (False, True):
        l_o = fields.artificial_current(l_a, n, goal, 0.3, continuous)
        assert l_o @ EY > 0.0 and abs(l_o @ n) < 1e-12


def test_c_other_obstacles_never_push_toward_the_nearest():
    # The case: moving +x along obstacle 1 (on the right, r = 0.4),
    # obstacle 2 ahead-left at r = 1.0.
    v = np.array([1.0, 0.0, 0.0])
    r_1 = -(0.4 + R) * EY
    r_2 = (1.0 + R) * np.array([np.cos(0.5), np.sin(0.5), 0.0])
    signal = obstacle_signal([r_1, r_2])
    goal = 10.0 * EX
    alone = sum(fields.obstacle_field(v, r_1, 1.0, goal, R, PAPER))
    paper = sum(fields.superposed(fields.obstacle_field, v, signal, goal, R, PAPER))
    params = only(project_others=True)
    projected = fields.superposed(fields.obstacle_field, v, signal, goal, R, params)
    assert alone @ EY > 0.5  # obstacle 1 alone turns away from it
    assert paper @ EY < 0.0  # the paper's sum turns toward it
    assert sum(projected) @ EY >= alone @ EY - 1e-12  # the repair does not
    for term in projected:  # and does no work
        assert abs(term @ v) < 1e-12


def test_d_avoidance_fades_at_hover():
    r_o = (0.3 + R) * EY
    goal = 10.0 * EX
    for speed in (0.03, 0.15, 0.3, 1.0):
        v = speed * np.array([0.6, 0.8, 0.0])
        _, F_a_paper = fields.obstacle_field(v, r_o, 1.0, goal, R, PAPER)
        _, F_a = fields.obstacle_field(v, r_o, 1.0, goal, R, only(hover_fade=True))
        scale = min(1.0, speed / REPAIRED.fade_speed)
        np.testing.assert_allclose(F_a, scale * F_a_paper, atol=1e-15)
    assert np.linalg.norm(F_a_paper) > 0.1


def test_e_goal_attraction_has_no_jump_near_opposite_headings():
    r_g = 5.0 * EX
    # Sweep the heading through the bisector's cut-off (|l_a + l_g| = 0.1,
    # about 174.3°) and on to opposite, in fine steps.
    angles = np.linspace(np.radians(170.0), np.radians(180.0), 20001)
    jumps = {}
    for smooth in (False, True):
        forces = [
            fields.goal_attraction_field(
                np.array([np.cos(a), np.sin(a), 0.1 * np.sin(a)]), r_g, 1.5, smooth
            )
            for a in angles
        ]
        jumps[smooth] = max(np.linalg.norm(np.diff(forces, axis=0), axis=1))
    assert jumps[False] > 1.0  # the paper's r_ref switch: a newton-sized jump
    assert jumps[True] < 1e-2  # the repair: steps of the order of the sweep's
    F = fields.goal_attraction_field(-EX, r_g, 1.5, True)  # exactly opposite
    assert np.linalg.norm(F) > 1.0 and abs(F @ EX) < 1e-12


def test_f_boundary_following_vanishes_continuously_at_its_range():
    v = np.array([1.2, 0.0, 0.3])  # approaching an obstacle ahead-left
    n = np.array([0.8, 0.6, 0.0])
    params = only(tapered_range=True)
    r_l = params.r_l
    for r in [0.2, 0.7, 1.2]:  # f = v (1/r − 1/r_l) against eq 13's v / r
        r_o = (r + R) * n
        F_paper, _ = fields.obstacle_field(v, r_o, 1.0, 10.0 * EX, R, PAPER)
        F, _ = fields.obstacle_field(v, r_o, 1.0, 10.0 * EX, R, params)
        np.testing.assert_allclose(F, F_paper * (1.0 - r / r_l), atol=1e-12)
        assert abs(F @ v) < 1e-12  # still no work
    # Across r_l: the paper's F jumps by c·v/r_l·sin, the tapered one by ~0.
    inside, outside = (r_l - 1e-9 + R) * n, (r_l + 1e-9 + R) * n
    for p, jump in [(PAPER, 1.0), (params, 1e-8)]:
        F_in, _ = fields.obstacle_field(v, inside, 1.0, 10.0 * EX, R, p)
        F_out, _ = fields.obstacle_field(v, outside, 1.0, 10.0 * EX, R, p)
        assert np.allclose(F_out, 0.0)
        assert (np.linalg.norm(F_in) > jump) == (p is PAPER)


def test_g_lag_drag_by_hand():
    """Eq 19 with repair (g), heading straight at the goal (F_gc = 0, |v| =
    v_d, so eq 19 alone is 0) under F_o = 3 N across v, by hand:
    τ = 2ζ/ω_n = 2·0.9/15 = 0.12 s, τω = τ|F⊥|/(m v) = 0.36/0.775 =
    0.4645161, (τω)² = 0.2157752, D = m v/τ · (τω)²/(1 + 2(τω)²) =
    6.4583333 · 0.2157752/1.4315505 = 0.9734539 N."""
    params = only(lag_drag=True)
    mass = VEHICLES["drake_default"].mass
    assert mass == 0.775 and fields.attitude_lag(params) == pytest.approx(0.12)
    p, v, goal = np.zeros(3), EX, 10.0 * EX
    F_o = 3.0 * EY
    cruise = fields.MODE_CRUISE
    F_gc, F_v, _ = fields.goal_terms(cruise, p, v, goal, params, F_o=F_o, mass=mass)
    np.testing.assert_allclose(F_gc, 0.0, atol=1e-15)
    np.testing.assert_allclose(F_v, [-0.9734539, 0.0, 0.0], atol=1e-7)
    # The paper's form, and (g) without F_o or the mass: eq 19 alone.
    for params_, F_o_, mass_ in [(PAPER, F_o, mass), (params, None, mass)]:
        _, F_v, _ = fields.goal_terms(cruise, p, v, goal, params_, F_o=F_o_, mass=mass_)
        np.testing.assert_allclose(F_v, 0.0, atol=1e-15)
    _, F_v, _ = fields.goal_terms(cruise, p, v, goal, params, F_o=F_o)
    np.testing.assert_allclose(F_v, 0.0, atol=1e-15)
    # A straight cruise (nothing turns the vehicle): no drag, eq 19's v_d.
    _, F_v, _ = fields.goal_terms(
        cruise, p, 0.7 * EX, goal, params, F_o=np.zeros(3), mass=mass
    )
    np.testing.assert_allclose(F_v, [params.K_v * 0.3, 0.0, 0.0], atol=1e-15)
    # The turning force is F_o + F_gc: a goal turn that cancels F_o, none.
    v = np.array([0.8, 0.6, 0.0])
    F_gc, F_v_alone, _ = fields.goal_terms(cruise, p, v, goal, PAPER)
    _, F_v, _ = fields.goal_terms(cruise, p, v, goal, params, F_o=-F_gc, mass=mass)
    np.testing.assert_allclose(F_v, F_v_alone, atol=1e-12)


def test_g_lag_drag_keeps_a_late_force_from_doing_work():
    """The command F⊥ − D l_a is ⟂ to the velocity τ later, v + τ(F⊥ − D
    l_a)/m, up to O((τω)⁴) (first order), while F⊥ itself does the work
    τ|F⊥|²/m; the drag never exceeds m v/(2τ)."""
    mass, tau = 0.775, 0.12
    v = np.array([1.2, 0.0, 0.3])
    l_a = v / np.linalg.norm(v)
    across = np.cross(l_a, EY)
    for size in (0.05, 0.2, 0.5):
        F_perp = size * across
        D = fields.lag_drag(v, F_perp, tau, mass)
        later = lambda F: v + tau * F / mass  # noqa: E731
        command = F_perp - D * l_a
        omega_tau = tau * size / (mass * np.linalg.norm(v))
        work = abs(command @ later(command))
        assert work < 4.0 * omega_tau**4 * mass * (v @ v) / tau
        assert F_perp @ later(F_perp) == pytest.approx(tau * size**2 / mass)
    for size in (1.0, 10.0, 1e3, 1e6):
        D = fields.lag_drag(v, size * across, tau, mass)
        assert 0.0 < D <= mass * np.linalg.norm(v) / (2.0 * tau)
    assert fields.lag_drag(np.zeros(3), across, tau, mass) == 0.0


def test_g_the_selector_brakes_with_the_vehicle_mass_and_F_o():
    """The selector hands its F_o input and the mass it was built with (the
    registry's MFI methods pass the vehicle's) to eq 19; its AutoDiffXd
    copy keeps the mass."""
    params = dataclasses.replace(REPAIRED, lag_drag=True)
    goal, x = 10.0 * EX, np.zeros(12)
    x[6:9] = [1.0, 0.2, 0.0]
    F_o = np.array([0.0, 3.0, 0.0])
    selector = GoalAttractionSelector(params, goal, fields.MODE_CRUISE, mass=0.775)
    context = selector.CreateDefaultContext()
    selector.GetInputPort("state").FixValue(context, x)
    selector.GetInputPort("obstacle_force").FixValue(context, F_o)
    terms = selector.GetOutputPort("goal_force_terms").Eval(context)
    F_gc, F_v, _ = fields.goal_terms(
        fields.MODE_CRUISE, x[:3], x[6:9], goal, params, F_o=F_o, mass=0.775
    )
    np.testing.assert_allclose(terms, np.concatenate([F_gc, F_v, np.zeros(3)]))
    _, F_v_eq19, _ = fields.goal_terms(fields.MODE_CRUISE, x[:3], x[6:9], goal, PAPER)
    assert (F_v - F_v_eq19) @ x[6:9] < -0.5  # it brakes
    np.testing.assert_allclose(
        selector.GetOutputPort("navigation_force").Eval(context), F_o + F_gc + F_v
    )
    assert selector.ToAutoDiffXd().mass == 0.775


def test_h_eq12_weighs_an_approached_obstacle_by_how_near_its_path_it_is():
    """Flying along x at cruise speed with the closest point at (d, y): the
    heading line passes it at |y|, the clearance m = |y| − ρ. Eq 12 weighs
    (1 − m)/0.5 clipped to [0, 1] (AHEAD_MISS = (0.5, 1) m), whatever the
    angle d sets: all of it at m = 0.4 and half at m = 0.75, near (d =
    0.2) or far (d = 1.2), none at m = 1.1 (d = 0.2, 0.8); receding (d < 0,
    the goal on the obstacle's side), (a)'s rule, eq 12 whole. F_a (eq 14)
    is untouched."""
    goal = 10.0 * EX
    a = only(follow_blocking_only=True)
    h = dataclasses.replace(a, follow_ahead_only=True)
    v = REPAIRED.v_d * EX
    cases = [(d, 0.4, 1.0) for d in (0.2, 1.2)] + [(d, 0.75, 0.5) for d in (0.2, 1.2)]
    cases += [(0.2, 1.1, 0.0), (0.8, 1.1, 0.0), (-0.4, 0.6, None)]
    for d, m, weight in cases:
        r_o = np.array([d, m + R, 0.0])
        # Receding, a goal on the obstacle's side, where (a) keeps eq 12 whole.
        to = 10.0 * EY if weight is None else goal
        F_a, B_a = fields.obstacle_field(v, r_o, 1.0, to, R, a)
        F_h, B_h = fields.obstacle_field(v, r_o, 1.0, to, R, h)
        np.testing.assert_allclose(B_h, B_a)
        assert np.linalg.norm(F_a) > 0.3
        if weight is None:
            np.testing.assert_allclose(F_h, F_a)
        else:
            np.testing.assert_allclose(F_h, weight * F_a, atol=1e-12)
    # Head-on the line passes through the closest point: m = −ρ, weight 1.
    assert fields.blocking_weight(EX, EX, goal, 0.5 * EX, R) == 1.0


def test_h_makes_no_limit_cycle_along_a_wall():
    """The planar wall, where (h) on the approach angle alone made the heading
    swing round its ramp along the face (+29 % steps): with the clearance
    term the flight takes no more steps than with (h) off, and its path is
    as long to 1 %."""
    path = os.path.join(SCENARIOS, "planar_wall.yaml")
    flights = {
        on: simulate(
            load_scenario(path, [("h", f"navigator: {{follow_ahead_only: {on}}}")]),
            until_settled=True,
        )
        for on in ("true", "false")
    }
    on, off = flights["true"], flights["false"]
    assert on.metrics["success"] and off.metrics["success"]
    assert on.integrator_steps <= 1.02 * off.integrator_steps
    assert on.metrics["path_length"] == pytest.approx(
        off.metrics["path_length"], rel=0.01
    )


@pytest.mark.parametrize("offset", [1e-9, -1e-9, 0.0])
def test_symmetric_two_spheres_fly_in_a_bounded_number_of_steps(offset):
    # A vehicle aimed exactly between two equal spheres, the aim off by
    # `offset`: no chattering side choice, so the integrator's steps stay few.
    scenario = Scenario(
        start=[0.0, offset, 1.5],
        goal=[10.0, 0.0, 1.5],
        duration=15.0,
        obstacles=[
            Obstacle(shape=Sphere(radius=1.5), position=[4.0, y, 1.5])
            for y in (2.0, -2.0)
        ],
    )
    metrics = simulate(scenario).metrics
    assert metrics["success"]
    assert metrics["steps"] < 1500
