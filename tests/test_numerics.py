"""Numerical robustness, property-based (hypothesis): every field function of
`fields`, `so3`, `quadcopter`, `baselines` and `faults` returns finite values
for all finite inputs, the singular configurations of docs/design.md included
(zero speed, head-on, velocity opposite the goal, obstacle distance near zero
or negative, goal reached, rotations by π), and the zero-work terms stay
perpendicular to v there.

"Finite inputs" are vectors with entries up to 1e6 in magnitude (m, m/s, N),
subnormals and signed zeros included; the singular cases are constructed on
purpose, since uniform random floats would almost never hit them.
"""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from mfi_drake.config.parameters import (
    REPAIRS,
    ApfParams,
    GfParams,
    NavigatorParams,
    paper_form,
)
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.maths import baselines, fields, so3
from mfi_drake.maths.faults import corrupt_reading, rotor_lag_rate, sample_rng
from mfi_drake.maths.quadcopter import (
    attitude_gains,
    attitude_pd_torque,
    attitude_setpoint,
    desired_yaw,
    mix,
    mixer_matrix,
    wrap_angle,
)

P = NavigatorParams()
# Variants of MFI: the default, every repair on (those off by default
# included), and the paper's form (every repair off).
VARIANTS = pytest.mark.parametrize(
    "params",
    [P, dataclasses.replace(P, **dict.fromkeys(REPAIRS, True)), paper_form(P)],
    ids=["default", "every_repair", "paper"],
)
P_YAW = NavigatorParams(yaw_follows_motion=True)
APF = ApfParams()
GF = GfParams()
RADIUS = VEHICLES["drake_default"].collision_radius
BIG = 1e6
FAST = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)

finite = st.floats(-BIG, BIG, allow_nan=False, allow_infinity=False)
vectors = st.lists(finite, min_size=3, max_size=3).map(np.array)
AXES = [np.array(a, float) for a in np.vstack([np.eye(3), -np.eye(3)])]


@st.composite
def unit_vectors(draw):
    """Random unit vectors, and the coordinate axes (where fallbacks switch)."""
    if draw(st.booleans()):
        return draw(st.sampled_from(AXES))
    x = draw(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array))
    size = np.linalg.norm(x)
    return x / size if size > 1e-3 else AXES[0]


@st.composite
def magnitudes(draw):
    """0, subnormal, tiny, ordinary and huge magnitudes."""
    return draw(
        st.one_of(
            st.just(0.0),
            st.just(5e-324),
            st.floats(0.0, 1e-8),
            st.floats(0.0, 10.0),
            st.floats(0.0, BIG),
        )
    )


@st.composite
def configurations(draw):
    """(v, r_o, r_g): the velocity, the closest-obstacle vector and the goal
    vector, built so that each singular configuration is drawn often."""
    n = draw(unit_vectors())
    distance = draw(
        st.one_of(
            st.just(0.0),
            st.floats(0.0, 1e-8),  # obstacle point at the centre
            st.floats(0.0, RADIUS),  # inside the grown obstacle: r < 0
            st.floats(RADIUS - 1e-6, RADIUS + 1e-6),  # r ≈ 0
            st.floats(0.0, 5.0),
            st.floats(0.0, BIG),
        )
    )
    r_o = distance * n
    r_g = draw(
        st.one_of(
            st.just(np.zeros(3)),  # goal reached
            magnitudes().flatmap(lambda m: unit_vectors().map(lambda u: m * u)),
            vectors,
        )
    )
    speed = draw(magnitudes())
    kind = draw(
        st.sampled_from(
            ["random", "head_on", "receding", "to_goal", "from_goal", "grazing"]
        )
    )
    g_size = np.linalg.norm(r_g)
    l_g = r_g / g_size if g_size > 0 else n
    direction = {
        "random": draw(unit_vectors()),
        "head_on": n,
        "receding": -n,
        "to_goal": l_g,
        "from_goal": -l_g,  # velocity opposite the goal
        "grazing": draw(unit_vectors()),
    }[kind]
    if kind == "grazing":  # exactly on the tangent plane
        t = direction - (direction @ n) * n
        direction = t / np.linalg.norm(t) if np.linalg.norm(t) > 1e-6 else n
    tilt = draw(st.sampled_from([0.0, 1e-12, 1e-6, 1e-3]))
    v = speed * (direction + tilt * draw(unit_vectors()))
    return v, r_o, r_g


def assert_finite(*arrays):
    for a in arrays:
        assert np.all(np.isfinite(np.asarray(a, float))), arrays


def assert_zero_work(F, v):
    """|F·v| ≤ 1e-9 |F||v|: the force does no work (up to rounding)."""
    F, v = np.asarray(F, float), np.asarray(v, float)
    # math.hypot scales before squaring: np.linalg.norm of a 1e-208 vector
    # underflows to 0 and would demand |F·v| ≤ 1e-300 of a tiny force.
    scale = math.hypot(*F) * math.hypot(*v)
    assert abs(F @ v) <= 1e-9 * scale + 1e-300, (F, v)


# --- fields (§IV) -------------------------------------------------------------
@VARIANTS
@FAST
@given(configurations(), st.sampled_from([0.0, 1.0]))
@example((np.array([1.0, 0, 0]), np.array([0.5, 0, 0]), np.zeros(3)), 1.0)
@example(  # a 1e-208 force: its norm, squared, underflows
    (
        np.array([1.0, -1e-12, 0.0]),
        np.array([0.0, 6.96845245e-09, 0.0]),
        np.array([0.0, 2.8739316814169353e-198, 135.0]),
    ),
    1.0,
)
@example((np.array([1.0, 0, 0]), np.array([RADIUS, 0, 0]), np.array([-5.0, 0, 0])), 1)
@example((np.zeros(3), np.array([0.3, 0, 0]), np.zeros(3)), 1.0)
def test_obstacle_field_is_finite_and_does_no_work(params, config, seen):
    v, r_o, r_g = config
    F, F_a = fields.obstacle_field(v, r_o, seen, r_g, RADIUS, params)
    assert_finite(F, F_a)
    assert_zero_work(F, v)
    assert_zero_work(F_a, v)


@pytest.mark.parametrize("continuous", [False, True])
@FAST
@given(configurations())
def test_artificial_current_is_finite_tangent_and_never_zero_head_on(
    continuous, config
):
    v, r_o, r_g = config
    speed, l_a = fields.heading(v)
    distance = np.linalg.norm(r_o)
    if speed < so3.TINY or distance < so3.TINY:
        return  # obstacle_field never calls it there
    n = r_o / distance
    l_o = fields.artificial_current(l_a, n, r_g, P.tangent_blend, continuous)
    assert_finite(l_o)
    assert abs(l_o @ n) <= 1e-9
    if l_a @ n > 0.0 and not continuous:
        # approaching: |l_o|² ≥ |eq 11's l_o|² + (blend − it)²
        assert np.linalg.norm(l_o) >= P.tangent_blend / np.sqrt(2.0) - 1e-9


@FAST
@given(unit_vectors(), st.one_of(st.just(np.zeros(3)), vectors))
def test_fallback_tangent_is_a_unit_tangent(n, r_g):
    t = fields.fallback_tangent(n, r_g)
    assert_finite(t)
    assert abs(np.linalg.norm(t) - 1.0) < 1e-9
    assert abs(t @ n) < 1e-9


@pytest.mark.parametrize("smooth", [False, True])
@FAST
@given(configurations(), st.sampled_from([0.0, 1.5, 1e3]))
@example((np.array([1.0, 0, 0]), np.zeros(3), np.array([-3.0, 0, 0])), 1.5)
@example((np.array([1.0, 0, 0]), np.zeros(3), np.array([3.0, 1e-13, 0])), 1.5)
@example((np.array([0, 0, -2.0]), np.zeros(3), np.array([0, 0, 4.0])), 1.5)
def test_goal_attraction_is_finite_and_does_no_work(smooth, config, K_omega):
    v, _, r_g = config
    F_gc = fields.goal_attraction_field(v, r_g, K_omega, smooth)
    assert_finite(F_gc)
    assert_zero_work(F_gc, v)


@VARIANTS
@FAST
@given(
    configurations(),
    vectors,
    st.sampled_from([fields.MODE_PD, fields.MODE_CRUISE]),
    vectors,
)
def test_goal_terms_and_guards_are_finite(params, config, p, mode, F_o):
    v, _, r_g = config
    goal = p + r_g
    mass = VEHICLES["drake_default"].mass  # repair (g)'s lag drag needs it
    F_gc, F_v, F_pd = fields.goal_terms(mode, p, v, goal, params, F_o=F_o, mass=mass)
    assert_finite(F_gc, F_v, F_pd)
    assert np.linalg.norm(F_pd) <= P.max_pd_force * (1 + 1e-12)
    assert np.linalg.norm(np.cross(F_v, v)) <= 1e-9 * max(
        np.linalg.norm(F_v) * np.linalg.norm(v), 1e-300
    )  # eq 19 acts along v
    assert_finite(fields.cruise_guard(p, v, goal, P), fields.pd_guard(p, v, goal, P))


# --- SO(3) (eq 16–17) ---------------------------------------------------------
def rotation(axis, angle):
    """Rodrigues' formula, independently of `so3`."""
    K = np.array(
        [[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]]
    )
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


@FAST
@given(unit_vectors(), unit_vectors())
@example(AXES[0], AXES[3])  # opposite: the bisector is undefined
@example(AXES[2], AXES[2])
def test_eq16_rotations_are_rotations_taking_the_reference_to_the_vector(a, b):
    r_ref = so3.reference_axis(a, b)
    for u in (a, b):
        R = so3.rotation_from_reference(r_ref, u)
        assert_finite(R)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
        assert np.linalg.det(R) > 0
        np.testing.assert_allclose(R @ r_ref, u, atol=1e-9)


@FAST
@given(unit_vectors(), st.one_of(st.floats(0.0, np.pi), st.sampled_from([0.0, np.pi])))
@example(AXES[0], np.pi)
@example(np.array([0.6, 0.8, 0.0]), np.pi)
@example(AXES[1], 1e-12)
def test_so3_log_is_finite_and_inverts_rodrigues(axis, angle):
    R = rotation(axis, angle)
    w = so3.vee(so3.so3_log(R))
    assert_finite(w)
    assert np.linalg.norm(w) <= np.pi + 1e-9
    theta = np.linalg.norm(w)
    back = rotation(w / theta, theta) if theta > 0 else np.eye(3)
    np.testing.assert_allclose(back, R, atol=1e-6)


# --- quadcopter chain (§V) ----------------------------------------------------
@FAST
@given(vectors, vectors, vectors, st.sampled_from(sorted(VEHICLES)), st.booleans())
def test_quadcopter_chain_is_finite_and_within_rotor_limits(
    F_n, attitude, rates, name, follow
):
    vehicle = VEHICLES[name]
    params = P_YAW if follow else P
    yaw_d = desired_yaw(rates, attitude[2], params)
    setpoint = attitude_setpoint(F_n, attitude, yaw_d, vehicle, params)
    assert_finite(yaw_d, setpoint)
    assert np.hypot(setpoint[1], setpoint[2]) <= params.max_tilt * (1 + 1e-12)
    K_P, K_D = attitude_gains(vehicle, params)
    tau = attitude_pd_torque(attitude, rates, setpoint[1:], K_P, K_D)
    assert_finite(tau)
    u, saturated = mix(
        np.concatenate([setpoint[:1], tau]),
        np.linalg.inv(mixer_matrix(vehicle)),
        vehicle.u_max,
    )
    assert_finite(u)
    assert np.all(u >= -1e-9 * vehicle.u_max) and np.all(
        u <= vehicle.u_max * (1 + 1e-9)
    )
    assert 0 <= saturated <= 4


@FAST
@given(finite)
def test_wrap_angle_lands_in_the_half_open_circle(angle):
    w = wrap_angle(angle)
    assert -np.pi <= w < np.pi
    assert abs(np.sin(w) - np.sin(angle)) < 1e-6


# --- baselines (APF, GF) ------------------------------------------------------
@FAST
@given(configurations(), vectors, st.sampled_from([0.0, 1.0]))
def test_baseline_fields_are_finite_and_gf_steering_does_no_work(config, p, seen):
    v, r_o, r_g = config
    goal = p + r_g
    a = APF.attraction
    assert_finite(
        baselines.attraction_field(p, v, goal, a),
        baselines.attraction_potential(p, goal, a),
        *baselines.apf_obstacle_field(v, r_o, seen, r_g, RADIUS, APF),
    )
    S_v, F_rep = baselines.gf_obstacle_field(v, r_o, seen, r_g, RADIUS, GF)
    assert_finite(S_v, F_rep)
    assert_zero_work(S_v, v)
    distance = np.linalg.norm(r_o)
    if distance > so3.TINY:
        n = r_o / distance
        r = max(distance - RADIUS, GF.min_distance)
        S = baselines.gyroscopic_matrix(v, n, r, r_g, GF)
        assert_finite(S)
        np.testing.assert_array_equal(S, -S.T)
        assert_finite(baselines.repulsive_potential(r, APF.eta, APF.rho_0))


@FAST
@given(configurations())
def test_gf_steering_direction_is_a_unit_vector_across_the_heading(config):
    v, r_o, r_g = config
    speed, l_a = fields.heading(v)
    distance = np.linalg.norm(r_o)
    if speed < so3.TINY or distance < so3.TINY:
        return  # gyroscopic_matrix never calls it there
    d = baselines.steering_direction(l_a, r_o / distance, r_g, GF.tangent_blend)
    assert_finite(d)
    assert abs(np.linalg.norm(d) - 1.0) < 1e-9
    assert abs(d @ l_a) < 1e-9


# --- faults -------------------------------------------------------------------
@FAST
@given(
    vectors,
    st.sampled_from([0.0, 1.0]),
    st.integers(0, 2**32),
    st.floats(0.0, 10.0),
    st.floats(0.0, 1.0),
)
def test_fault_models_are_finite(r_o, seen, k, std, p):
    reading = corrupt_reading(np.append(r_o, seen), sample_rng(0, 0, k), std, p)
    assert_finite(reading)
    assert reading[3] in (0.0, seen)
    u = np.abs(r_o)
    assert_finite(rotor_lag_rate(u[::-1], u, 0.0125, 0.025))
