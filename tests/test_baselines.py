"""The APF and GF baselines against independent oracles: APF is minus the
numerical gradient of its potential; GF's gyroscopic part does no work, turns
away from the obstacle and has a deterministic head-on fallback."""

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd, ExtractValue, InitializeAutoDiff

from mfi_drake.config.parameters import ApfParams, AttractionParams, GfParams
from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.flight.diagram import build_diagram
from mfi_drake.maths import baselines
from mfi_drake.maths.baselines import (
    apf_obstacle_field,
    attraction_field,
    attraction_potential,
    gf_obstacle_field,
    gyroscopic_matrix,
    repulsive_potential,
)
from mfi_drake.maths.layout import obstacle_signal
from mfi_drake.systems.navigation import (
    ApfNavigator,
    GfNavigator,
    PotentialGoalAttraction,
)
from mfi_drake.world.validation import load_scenario

RADIUS = 0.2  # collision radius for these tests [m]
CENTRE, SPHERE = np.array([3.0, 0.5, 1.0]), 0.8  # a sphere obstacle
GOAL = np.array([6.0, 0.0, 1.0])
APF = ApfParams(eta=0.3, rho_0=1.2)
GF = GfParams(k_g=3.0, r_d=2.0, eta=0.05, rho_0=0.5)


def unit(x):
    return x / np.linalg.norm(x)


def sphere_r_o(p):
    """The vector from p to the sphere's closest point (the sensor's r_o)."""
    to_centre = CENTRE - p
    return to_centre * (1.0 - SPHERE / np.linalg.norm(to_centre))


def apf_potential(p):
    r = np.linalg.norm(CENTRE - p) - SPHERE - RADIUS
    return attraction_potential(p, GOAL, APF.attraction) + repulsive_potential(
        r, APF.eta, APF.rho_0
    )


def numerical_gradient(f, p, h=1e-6):
    return np.array([(f(p + h * e) - f(p - h * e)) / (2 * h) for e in np.eye(3)])


def points_near_the_sphere(n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        gap = rng.uniform(0.05, 1.6)  # inside and outside rho_0
        yield CENTRE + unit(rng.normal(size=3)) * (SPHERE + RADIUS + gap)


def test_apf_force_is_minus_the_numerical_gradient_of_its_potential():
    checked_inside = 0
    for p in points_near_the_sphere(200):
        v = np.zeros(3)
        F_rep, zero = apf_obstacle_field(v, sphere_r_o(p), 1.0, GOAL - p, RADIUS, APF)
        F = attraction_field(p, v, GOAL, APF.attraction) + F_rep
        np.testing.assert_allclose(
            F, -numerical_gradient(apf_potential, p), rtol=1e-5, atol=1e-6
        )
        assert np.all(zero == 0.0)
        checked_inside += np.linalg.norm(F_rep) > 0
    assert checked_inside > 50  # the repulsion was really exercised


def test_attraction_is_eq20_near_the_goal_and_cruises_at_v_max_far_away():
    a = AttractionParams(k_att=1.5, k_d=2.0, v_max=1.0)
    d_star = a.k_d * a.v_max / a.k_att
    rng = np.random.default_rng(1)
    for _ in range(50):
        v = rng.normal(size=3)
        e = unit(rng.normal(size=3))
        near = GOAL + 0.9 * d_star * e
        np.testing.assert_allclose(
            attraction_field(near, v, GOAL, a), -a.k_att * (near - GOAL) - a.k_d * v
        )
        far = GOAL + 5.0 * d_star * e
        # the velocity at which the far-field force vanishes is v_max toward p_g
        np.testing.assert_allclose(
            attraction_field(far, -a.v_max * e, GOAL, a), 0.0, atol=1e-12
        )
    # continuous across d*
    e = unit(np.array([1.0, 2.0, -0.5]))
    inside = attraction_field(GOAL + (d_star - 1e-9) * e, np.zeros(3), GOAL, a)
    outside = attraction_field(GOAL + (d_star + 1e-9) * e, np.zeros(3), GOAL, a)
    np.testing.assert_allclose(inside, outside, atol=1e-8)


def test_obstacle_fields_vanish_when_nothing_is_seen_or_out_of_range():
    v, r_g = np.array([1.0, 0.0, 0.0]), np.array([5.0, 0.0, 0.0])
    far = np.array([APF.rho_0 + RADIUS + 0.01, 0.0, 0.0])
    for r_o, seen in [(far, 1.0), (np.array([0.5, 0.0, 0.0]), 0.0)]:
        assert not np.any(apf_obstacle_field(v, r_o, seen, r_g, RADIUS, APF)[0])
    shell = np.array([GF.r_d + RADIUS + 0.01, 0.0, 0.0])
    for r_o, seen in [(shell, 1.0), (np.array([0.5, 0.0, 0.0]), 0.0)]:
        assert not np.any(
            np.concatenate(gf_obstacle_field(v, r_o, seen, r_g, RADIUS, GF))
        )


def random_gf_inputs(n, seed=2):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        v = rng.normal(size=3) * rng.uniform(0.1, 3.0)
        n_ = unit(rng.normal(size=3))
        r = rng.uniform(0.05, 2.5)
        yield v, n_, r, rng.normal(size=3) * 5


def test_gyroscopic_part_is_skew_and_does_zero_work():
    active = 0
    for v, n, r, r_g in random_gf_inputs(500):
        S = gyroscopic_matrix(v, n, r, r_g, GF)
        np.testing.assert_allclose(S, -S.T, atol=1e-15)
        assert abs((S @ v) @ v) <= 1e-12 * max(1.0, np.linalg.norm(S @ v))
        active += np.linalg.norm(S @ v) > 0
    assert active > 100


def test_gyroscopic_part_turns_away_only_while_approaching_inside_the_shell():
    for v, n, r, r_g in random_gf_inputs(500, seed=3):
        F = gyroscopic_matrix(v, n, r, r_g, GF) @ v
        if v @ n > 0 and r < GF.r_d:
            assert F @ n < 0.0  # the heading turns away from the obstacle
            l_a = unit(v)
            expected = GF.k_g * np.linalg.norm(v) * (1 / r - 1 / GF.r_d) * (l_a @ n)
            assert np.linalg.norm(F) == pytest.approx(expected)
        else:
            assert not np.any(F)


@pytest.mark.parametrize(
    "n, r_g, expected",
    [
        # goal off to −y beyond a wall ahead: go round on the goal's side
        ([1.0, 0.0, 0.0], [5.0, -1.0, 0.0], [0.0, -1.0, 0.0]),
        # goal straight behind: horizontal e_z × n
        ([1.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        # obstacle straight above, goal above it: e_x × n
        ([0.0, 0.0, 1.0], [0.0, 0.0, 5.0], [0.0, -1.0, 0.0]),
    ],
)
def test_head_on_fallback_is_deterministic_and_perpendicular(n, r_g, expected):
    n, r_g = np.array(n), np.array(r_g)
    v = 1.3 * n  # v ∥ n: n⊥ = 0 and the plain steering direction is undefined
    F = gyroscopic_matrix(v, n, 0.5, r_g, GF) @ v
    assert np.linalg.norm(F) > 0.1
    np.testing.assert_allclose(unit(F), expected, atol=1e-12)
    np.testing.assert_array_equal(F, gyroscopic_matrix(v, n, 0.5, r_g, GF) @ v)


def test_blended_direction_stays_unit_perpendicular_and_on_the_away_side():
    rng = np.random.default_rng(4)
    for _ in range(300):
        n = unit(rng.normal(size=3))
        # headings within the blend cone around n (|n⊥| < tangent_blend)
        l_a = unit(n + rng.uniform(0.0, 0.3) * unit(rng.normal(size=3)))
        d = baselines.steering_direction(
            l_a, n, rng.normal(size=3) * 5, GF.tangent_blend
        )
        away = (l_a @ n) * l_a - n  # −n⊥
        assert np.linalg.norm(d) == pytest.approx(1.0)
        assert abs(d @ l_a) < 1e-12
        assert d @ away >= -1e-12


def test_fallback_blend_is_continuous_at_its_edge():
    n, r_g = np.array([1.0, 0.0, 0.0]), np.array([5.0, 0.0, 2.0])
    # l_a with |n⊥| = sin(angle) just below and just above tangent_blend
    angle = np.arcsin(GF.tangent_blend)
    forces = []
    for a in (angle - 1e-7, angle + 1e-7):
        v = np.array([np.cos(a), np.sin(a), 0.0])
        forces.append(gyroscopic_matrix(v, n, 0.5, r_g, GF) @ v)
    np.testing.assert_allclose(forces[0], forces[1], atol=1e-5)


def test_fields_accept_autodiff_and_match_float():
    v, r_o, r_g = np.array([0.9, 0.2, -0.1]), np.array([0.6, 0.1, 0.05]), GOAL
    x = InitializeAutoDiff(np.concatenate([v, r_o]))[:, 0]
    v_ad, r_o_ad = x[:3], x[3:]
    for field, params in ((apf_obstacle_field, APF), (gf_obstacle_field, GF)):
        expected = np.concatenate(field(v, r_o, 1.0, r_g, RADIUS, params))
        got = np.concatenate(field(v_ad, r_o_ad, 1.0, r_g, RADIUS, params))
        assert isinstance(got[0], AutoDiffXd)
        np.testing.assert_allclose(ExtractValue(got)[:, 0], expected)


def evaluate(system, inputs):
    context = system.CreateDefaultContext()
    for name, value in inputs.items():
        system.GetInputPort(name).FixValue(context, value)
    return context, system


def test_navigator_systems_are_thin_adapters_over_the_fields():
    x = np.zeros(12)
    x[0:3], x[6:9] = [1.0, 0.2, 1.5], [0.8, 0.1, 0.0]
    r_1, r_2 = np.array([0.5, 0.05, 0.0]), np.array([-0.2, 0.6, 0.1])
    obstacle = obstacle_signal([r_1, r_2])
    for make, field, params in (
        (ApfNavigator, apf_obstacle_field, APF),
        (GfNavigator, gf_obstacle_field, GF),
    ):
        context, system = evaluate(
            make(params, GOAL, RADIUS), {"state": x, "obstacle": obstacle}
        )
        # Two obstacles seen: the sum of each one's terms.
        A_1, B_1 = field(x[6:9], r_1, 1.0, GOAL - x[:3], RADIUS, params)
        A_2, B_2 = field(x[6:9], r_2, 1.0, GOAL - x[:3], RADIUS, params)
        A, B = A_1 + A_2, B_1 + B_2
        terms = system.GetOutputPort("obstacle_force_terms").Eval(context)
        np.testing.assert_allclose(terms, np.concatenate([A, B]))
        force = system.GetOutputPort("obstacle_force").Eval(context)
        np.testing.assert_allclose(force, A + B)
        assert np.linalg.norm(force) > 0


def test_potential_goal_attraction_adds_the_attraction_to_F_o():
    x = np.zeros(12)
    x[0:3], x[6:9] = [1.0, 0.2, 1.5], [0.8, 0.1, 0.0]
    F_o = np.array([-0.3, 0.4, 0.1])
    context, system = evaluate(
        PotentialGoalAttraction(APF.attraction, GOAL),
        {"state": x, "obstacle_force": F_o},
    )
    F_att = attraction_field(x[:3], x[6:9], GOAL, APF.attraction)
    np.testing.assert_allclose(
        system.GetOutputPort("navigation_force").Eval(context), F_o + F_att
    )
    terms = system.GetOutputPort("goal_force_terms").Eval(context)
    np.testing.assert_allclose(terms, np.concatenate([np.zeros(6), F_att]))


def test_baseline_systems_convert_to_autodiff():
    for system in (
        ApfNavigator(APF, GOAL, RADIUS),
        GfNavigator(GF, GOAL, RADIUS),
        PotentialGoalAttraction(GF.attraction, GOAL),
    ):
        converted = system.ToAutoDiffXd()
        assert converted.num_output_ports() == system.num_output_ports()


@pytest.mark.parametrize("method", ["apf", "gf"])
def test_baseline_diagram_has_the_mfi_ports_and_log(method):
    flight = build_diagram(Scenario(goal=[5.0, 0.0, 1.5]), method)
    navigator = flight.diagram.GetSubsystemByName("navigator")
    for port in ("obstacle_force", "obstacle_force_terms"):
        assert navigator.HasOutputPort(port)
    selector = flight.diagram.GetSubsystemByName("selector")
    assert selector.num_discrete_state_groups() == 0


@pytest.mark.parametrize(
    "text, named",
    [
        ("apf: {eta: -1.0}", "apf.eta = -1.0"),
        ("apf: {attraction: {k_d: 0.0}}", "apf.attraction.k_d = 0.0"),
        ("gf: {r_d: 1.0, rho_0: 1.5}", "gf.rho_0 = 1.5"),
        ("gf: {tangent_blend: 1.5}", "gf.tangent_blend = 1.5"),
    ],
)
def test_bad_baseline_gains_are_named(write_yaml, text, named):
    with pytest.raises(ScenarioError, match=named.replace(".", r"\.")):
        load_scenario(write_yaml(f"name: t\ngoal: [5, 0, 1.5]\n{text}\n"))


def test_baseline_gains_load_from_the_scenario(write_yaml):
    scenario = load_scenario(
        write_yaml(
            "name: t\ngoal: [5, 0, 1.5]\n"
            "apf: {eta: 0.7, attraction: {v_max: 0.5}}\ngf: {k_g: 9}\n"
        )
    )
    assert scenario.apf.eta == 0.7 and scenario.apf.attraction.v_max == 0.5
    # the unnamed fields keep APF's own defaults, not AttractionParams'
    assert scenario.apf.attraction.k_att == ApfParams().attraction.k_att
    assert scenario.gf.k_g == 9.0
