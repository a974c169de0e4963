"""The navigation field of §IV against closed forms, docs/design.md's expanded
forms and the zero-work property."""

import numpy as np
import pytest

from mfi_drake.config.parameters import NavigatorParams, paper_form
from mfi_drake.maths import fields
from mfi_drake.maths.layout import obstacle_signal

P = paper_form(NavigatorParams())  # the paper's literal eq 11–21
RADIUS = 0.2  # a collision radius for these tests [m]


def unit(x):
    return x / np.linalg.norm(x)


def random_states(n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        v = rng.normal(size=3) * rng.uniform(0.1, 3.0)
        r_o = unit(rng.normal(size=3)) * rng.uniform(RADIUS + 0.01, RADIUS + 2.0)
        r_g = rng.normal(size=3) * 5
        yield v, r_o, r_g


def test_eq11_current_is_the_tangent_projection_away_from_head_on():
    rng = np.random.default_rng(3)
    for _ in range(100):
        l_a, n = unit(rng.normal(size=3)), unit(rng.normal(size=3))
        l_o = fields.artificial_current(l_a, n, rng.normal(size=3), P.tangent_blend)
        expected = l_a - (l_a @ n) * n
        if l_a @ n <= 0 or np.linalg.norm(expected) >= P.tangent_blend:
            np.testing.assert_allclose(l_o, expected, atol=1e-14)
        assert abs(l_o @ n) < 1e-12  # always on the tangent plane


def test_eq12_boundary_field_matches_the_expanded_form_and_cutoff():
    for v, r_o, r_g in random_states(100):
        speed, l_a = np.linalg.norm(v), unit(v)
        n = unit(r_o)
        r = np.linalg.norm(r_o) - RADIUS
        F, _ = fields.obstacle_field(v, r_o, 1.0, r_g, RADIUS, P)
        l_o = fields.artificial_current(l_a, n, r_g, P.tangent_blend)
        expanded = (l_o - (l_a @ l_o) * l_a) * P.c * speed / r if r < P.r_l else 0 * v
        np.testing.assert_allclose(F, expanded, atol=1e-12)


def test_eq14_avoidance_field_matches_notes_expanded_form():
    for v, r_o, r_g in random_states(100, seed=1):
        l_a, n = unit(v), unit(r_o)
        r = max(np.linalg.norm(r_o) - RADIUS, P.min_distance)
        _, F_a = fields.obstacle_field(v, r_o, 1.0, r_g, RADIUS, P)
        l_o = l_a - (l_a @ n) * n
        if l_a @ n > 0 and np.linalg.norm(l_o) < P.tangent_blend:
            continue  # blended current: covered by the head-on tests
        f_a = P.c_perp * (1 / r - 1 / P.r_b) / r**2 if r < P.r_b else 0.0
        expected = f_a * ((l_a @ n) * l_o - (l_o @ l_o) * n)
        np.testing.assert_allclose(F_a, expected, atol=1e-9 * max(1.0, abs(f_a)))
        assert F_a @ n <= 1e-12  # never pulls toward the obstacle


def test_obstacle_terms_do_zero_work_for_random_inputs():
    for v, r_o, r_g in random_states(500, seed=2):
        F, F_a = fields.obstacle_field(v, r_o, 1.0, r_g, RADIUS, P)
        scale = 1 + np.linalg.norm(F) + np.linalg.norm(F_a)
        assert abs(F @ v) <= 1e-12 * scale * np.linalg.norm(v)
        assert abs(F_a @ v) <= 1e-12 * scale * np.linalg.norm(v)


def test_superposed_field_sums_the_readings_and_does_no_work():
    """Two walls either side of a corridor, the vehicle on its axis: their
    eq 14–15 terms cancel (no push to one side); off the axis the nearer
    wall wins. Unseen readings add nothing; the sum does no work."""
    v, r_g = np.array([1.0, 0, 0]), np.array([8.0, 0, 0])
    gap = 0.3 + RADIUS
    left, right = [0.1, gap, 0.0], [0.1, -gap, 0.0]
    F, F_a = fields.superposed(
        fields.obstacle_field, v, obstacle_signal([left, right]), r_g, RADIUS, P
    )
    np.testing.assert_allclose(F + F_a, np.zeros(3), atol=1e-12)
    nearer = [0.1, gap - 0.1, 0.0]
    F, F_a = fields.superposed(
        fields.obstacle_field, v, obstacle_signal([nearer, right]), r_g, RADIUS, P
    )
    assert (F + F_a)[1] < 0  # turned away from the nearer (left, +y) wall
    alone = fields.obstacle_field(v, np.array(nearer), 1.0, r_g, RADIUS, P)
    np.testing.assert_allclose(
        fields.superposed(
            fields.obstacle_field, v, obstacle_signal([nearer]), r_g, RADIUS, P
        ),
        alone,
    )
    for v, r_o, r_g in random_states(200, seed=5):
        readings = obstacle_signal([r_o, -0.7 * r_o[::-1], 0.5 * r_o])
        F, F_a = fields.superposed(fields.obstacle_field, v, readings, r_g, RADIUS, P)
        scale = 1 + np.linalg.norm(F) + np.linalg.norm(F_a)
        assert abs((F + F_a) @ v) <= 1e-12 * scale * np.linalg.norm(v)


def test_nothing_seen_rest_or_far_gives_no_obstacle_force():
    v, r_o, r_g = np.array([1.0, 0, 0]), np.array([0.5, 0, 0]), np.array([5.0, 0, 0])
    zero = np.zeros(3)
    for args in [(v, r_o, 0.0), (zero, r_o, 1.0), (v, np.array([5.0, 0, 0]), 1.0)]:
        F, F_a = fields.obstacle_field(*args, r_g, RADIUS, P)
        np.testing.assert_array_equal(F, zero)
        np.testing.assert_array_equal(F_a, zero)


def test_head_on_approach_turns_deterministically_toward_the_goal_side():
    v = np.array([1.0, 0.0, 0.0])
    r_o = np.array([0.8, 0.0, 0.0])  # wall straight ahead
    r_g = np.array([5.0, 1.0, 0.0])  # goal behind it, a little to +y
    F1, F_a1 = fields.obstacle_field(v, r_o, 1.0, r_g, RADIUS, P)
    F2, _ = fields.obstacle_field(v, r_o, 1.0, r_g, RADIUS, P)
    np.testing.assert_array_equal(F1, F2)
    assert F1[1] > 0.1 and abs(F1[0]) < 1e-12 and abs(F1[2]) < 1e-12
    # Goal exactly behind: the fallback goes round horizontally (e_z × n).
    F3, _ = fields.obstacle_field(v, r_o, 1.0, np.array([5.0, 0, 0]), RADIUS, P)
    assert abs(F3[1]) > 0.1 and abs(F3[2]) < 1e-12


def test_fields_stay_finite_at_contact():
    v = np.array([1.0, 0.2, 0.0])
    for d in [RADIUS, RADIUS - 0.1, 1e-12, 0.0]:
        F, F_a = fields.obstacle_field(
            v, np.array([d, 0, 0]), 1.0, np.ones(3), RADIUS, P
        )
        assert np.all(np.isfinite(F)) and np.all(np.isfinite(F_a))


def test_eq18_goal_attraction_closed_form_in_a_plane():
    # With r_ref the bisector, F_gc = K_ω β |v| toward the goal, ⟂ v.
    for beta in [1e-6, 0.1, 1.0, 2.0, 3.0]:
        v = 1.3 * np.array([1.0, 0.0, 0.0])
        r_g = 4.0 * np.array([np.cos(beta), np.sin(beta), 0.0])
        F = fields.goal_attraction_field(v, r_g, 1.5)
        np.testing.assert_allclose(F, [0.0, 1.5 * beta * 1.3, 0.0], atol=1e-9)


def test_goal_attraction_does_no_work_and_turns_toward_the_goal():
    rng = np.random.default_rng(4)
    for _ in range(300):
        v, r_g = rng.normal(size=3), rng.normal(size=3) * 4
        F = fields.goal_attraction_field(v, r_g, 1.0)
        assert abs(F @ v) < 1e-12 * (1 + np.linalg.norm(F)) * np.linalg.norm(v)
        l_a, l_g = unit(v), unit(r_g)
        toward = l_g - (l_g @ l_a) * l_a
        assert F @ toward > -1e-12


def test_goal_attraction_singular_cases_are_finite_and_deterministic():
    v = np.array([1.0, 0.0, 0.0])
    opposite = fields.goal_attraction_field(v, np.array([-3.0, 0, 0]), 1.0)
    assert np.all(np.isfinite(opposite)) and np.linalg.norm(opposite) > 1.0
    np.testing.assert_array_equal(
        opposite, fields.goal_attraction_field(v, np.array([-3.0, 0, 0]), 1.0)
    )
    # Nearly opposite, on either side of the bisector cut-off: still turning.
    for eps in [1e-3, 0.05, 0.2]:
        F = fields.goal_attraction_field(v, np.array([-1.0, eps, 0]), 1.0)
        assert np.all(np.isfinite(F)) and np.linalg.norm(F) > 1.0
    np.testing.assert_array_equal(fields.goal_attraction_field(0 * v, v, 1.0), 0 * v)
    np.testing.assert_array_equal(fields.goal_attraction_field(v, 0 * v, 1.0), 0 * v)
    aligned = fields.goal_attraction_field(v, np.array([2.0, 0, 0]), 1.0)
    np.testing.assert_allclose(aligned, 0 * v, atol=1e-15)


def test_eq19_speed_control_and_eq20_saturated_pd():
    v = np.array([0.0, 2.0, 0.0])
    np.testing.assert_allclose(fields.speed_control_field(v, 1.5, 1.0), [0, -1.5, 0])
    np.testing.assert_array_equal(fields.speed_control_field(0 * v, 1.5, 1.0), 0 * v)
    p, goal = np.zeros(3), np.array([0.5, 0.0, 0.0])
    np.testing.assert_allclose(
        fields.terminal_pd_field(p, 0 * v, goal, P), [P.K_P * 0.5, 0, 0]
    )
    far = fields.terminal_pd_field(p, 0 * v, np.array([100.0, 0, 0]), P)
    assert np.linalg.norm(far) == pytest.approx(P.max_pd_force)


def test_eq21_guards_select_the_mode():
    goal = np.array([10.0, 0, 0])
    p = np.zeros(3)
    assert fields.cruise_guard(p, np.zeros(3), goal, P) < 0  # at rest: PD
    assert fields.cruise_guard(p, np.array([1.0, 0, 0]), goal, P) > 0
    assert fields.pd_guard(p, np.array([1.0, 0, 0]), goal, P) > 0  # keep cruising
    assert fields.pd_guard(goal - [0.5, 0, 0], np.array([1.0, 0, 0]), goal, P) < 0
    assert fields.pd_guard(p, np.array([0.01, 0, 0]), goal, P) < 0  # stalled
    F_gc, F_v, F_pd = fields.goal_terms(fields.MODE_PD, p, np.ones(3), goal, P)
    assert not F_gc.any() and not F_v.any() and F_pd.any()
    # next_mode: each mode leaves only across its own guard (the hysteresis:
    # 0.1 m/s is below v_min, so PD stays, but above v_stop, so cruise stays).
    PD, CRUISE = fields.MODE_PD, fields.MODE_CRUISE
    slow, fast = np.array([0.1, 0, 0]), np.array([1.0, 0, 0])
    assert fields.next_mode(PD, p, fast, goal, P) == CRUISE
    assert fields.next_mode(PD, p, slow, goal, P) == PD
    assert fields.next_mode(CRUISE, p, slow, goal, P) == CRUISE
    assert fields.next_mode(CRUISE, p, np.zeros(3), goal, P) == PD
    assert fields.next_mode(CRUISE, goal - [0.5, 0, 0], fast, goal, P) == PD
