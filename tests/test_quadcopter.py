"""§V chain: the mixer against QuadrotorPlant's own dynamics, the signs of
roll and pitch (Drake's convention) by flying, and rotor saturation."""

import dataclasses

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.diagram import make_plant
from mfi_drake.maths.constants import GRAVITY
from mfi_drake.maths.quadcopter import (
    attitude_setpoint,
    mix,
    mixer_matrix,
    plus_commands,
    wrap_angle,
)
from mfi_drake.systems.control import AttitudePD, RotorMixer

P = NavigatorParams()


@pytest.mark.parametrize("name", sorted(VEHICLES))
def test_mixer_matrix_matches_the_plant_dynamics(name):
    """[T, τ] = D u, read back from the plant's accelerations at rest (an "x"
    vehicle's u reaches Drake's "+" plant through `plus_commands`)."""
    vehicle = VEHICLES[name]
    plant = make_plant(vehicle)
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(0)
    D = mixer_matrix(vehicle)
    for _ in range(5):
        u = rng.uniform(0.2, 1.0, size=4) * vehicle.u_max
        plant.get_input_port(0).FixValue(context, plus_commands(vehicle) @ u)
        xdot = plant.EvalTimeDerivatives(context).CopyToVector()
        T, tau = (D @ u)[0], (D @ u)[1:]
        assert xdot[8] == pytest.approx(T / vehicle.mass - GRAVITY, rel=1e-12)
        np.testing.assert_allclose(
            xdot[9:12], tau / np.asarray(vehicle.inertia), rtol=1e-9
        )


def test_mix_inverts_eq8_when_feasible_and_clips_otherwise():
    vehicle = VEHICLES["drake_default"]
    D = mixer_matrix(vehicle)
    D_inv = np.linalg.inv(D)
    gamma = np.array([vehicle.weight, 0.02, -0.03, 0.005])
    u, clipped = mix(gamma, D_inv, vehicle.u_max)
    assert clipped == 0
    np.testing.assert_allclose(D @ u, gamma, atol=1e-12)
    # Too much thrust: limits hold, roll/pitch torque is kept, clipping reported.
    gamma = np.array([30.0, 0.05, 0.0, 0.01])
    u, clipped = mix(gamma, D_inv, vehicle.u_max)
    assert clipped >= 1
    assert np.all(u >= 0) and np.all(u <= vehicle.u_max + 1e-12)
    np.testing.assert_allclose((D @ u)[1:3], gamma[1:3], atol=1e-12)
    # Negative thrust: all rotors off, reported.
    u, clipped = mix(np.array([-5.0, 0, 0, 0]), D_inv, vehicle.u_max)
    np.testing.assert_array_equal(u, np.zeros(4))
    assert clipped == 4


@pytest.mark.parametrize("name", sorted(VEHICLES))
def test_setpoint_delivers_F_n_or_a_fraction_of_it_in_its_direction(name):
    """Level vehicle, any yaw: the small-angle force the setpoint delivers,
    T (sin pitch_d forward, −sin roll_d left) + (T − m g) e_z ≈ K_Pv-weighted
    [tilt T, T − m g], is k F_n with k ∈ (0, 1], k = 1 exactly when F_n is
    within the thrust floor and the tilt limit, and the limits hold."""
    vehicle = VEHICLES[name]
    rng = np.random.default_rng(1)
    T_min = P.min_thrust_fraction * vehicle.weight
    for scale in (0.5, 5.0, 50.0):
        for _ in range(200):
            F_n = rng.normal(size=3) * scale * vehicle.weight / 5
            yaw = rng.uniform(-np.pi, np.pi)
            T, roll, pitch, _ = attitude_setpoint(
                F_n, np.array([0, 0, yaw]), 0.0, vehicle, P
            )
            forward, left = pitch * T, -roll * T  # eq 24 inverted
            c, s = np.cos(yaw), np.sin(yaw)
            delivered = np.array(
                [c * forward - s * left, s * forward + c * left, T - vehicle.weight]
            )
            k = delivered @ F_n / (F_n @ F_n)
            np.testing.assert_allclose(delivered, k * F_n, atol=1e-9 * scale)
            assert 0 < k <= 1 + 1e-12
            assert T >= T_min * (1 - 1e-12)
            assert np.hypot(roll, pitch) <= P.max_tilt * (1 + 1e-12)
            thrust = F_n[2] + vehicle.weight
            if thrust >= T_min and np.hypot(*F_n[:2]) <= P.max_tilt * thrust:
                assert k == pytest.approx(1.0)
            else:  # a limit binds
                assert T == pytest.approx(T_min) or np.hypot(
                    roll, pitch
                ) == pytest.approx(P.max_tilt)


def test_setpoint_signs_follow_drakes_convention():
    vehicle = VEHICLES["drake_default"]
    level = np.zeros(3)
    T, roll, pitch, _ = attitude_setpoint(np.array([1.0, 0, 0]), level, 0.0, vehicle, P)
    assert pitch > 0 and roll == 0 and T == pytest.approx(vehicle.weight)
    _, roll, pitch, _ = attitude_setpoint(np.array([0, 1.0, 0]), level, 0.0, vehicle, P)
    assert roll < 0 and pitch == 0  # +roll accelerates toward −y
    # Facing +y (yaw = π/2), a +y force is a forward force: +pitch.
    yawed = np.array([0, 0, np.pi / 2])
    _, roll, pitch, _ = attitude_setpoint(np.array([0, 1.0, 0]), yawed, 0.0, vehicle, P)
    assert pitch > 0 and abs(roll) < 1e-12
    # F_n pulls down 45° far harder than gravity: scaled by hand-computed
    # k = max_tilt m g / (|F_h| + max_tilt |F_z|) (the tilt bound binds; the
    # thrust bound would allow 0.9 m g / 50), keeping its direction.
    T, roll, pitch, _ = attitude_setpoint(
        np.array([50.0, 0, -50.0]), level, 0, vehicle, P
    )
    k = P.max_tilt * vehicle.weight / (50.0 + P.max_tilt * 50.0)
    assert T == pytest.approx(vehicle.weight - 50.0 * k)
    assert pitch == pytest.approx(P.max_tilt) and roll == 0
    assert wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)


def _delivered(T, roll, pitch, yaw, weight):
    """The force a setpoint delivers (eq 24 inverted, K_Pv = 1)."""
    forward, left = pitch * T, -roll * T
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c * forward - s * left, s * forward + c * left, T - weight])


def test_brake_first_keeps_the_braking_and_scales_the_rest_by_hand():
    """Level, v along +x, L = max_tilt m g of horizontal force to give, δ the
    brake margin: F_n = (−2, 10, 0) N (its braking fits with room to spare)
    is delivered as (−2, k·10, 0) with |(−2, 10k)| = L; F_n = (−10, 10, 0)
    N brakes (1 − δ) L and turns with the rest, (−(1 − δ) L, √(2δ − δ²) L,
    0)."""
    vehicle = VEHICLES["drake_default"]
    params = dataclasses.replace(P, brake_first=True)
    limit = P.max_tilt * vehicle.weight
    v = np.array([1.0, 0.0, 0.0])
    setpoint = attitude_setpoint(
        np.array([-2.0, 10, 0]), np.zeros(3), 0, vehicle, params, v
    )
    k = np.sqrt(limit**2 - 4.0) / 10.0
    np.testing.assert_allclose(
        _delivered(*setpoint[:3], 0.0, vehicle.weight), [-2.0, 10 * k, 0], atol=1e-12
    )
    for margin in (0.0, 0.1, 0.5):
        params = dataclasses.replace(P, brake_first=True, brake_margin=margin)
        setpoint = attitude_setpoint(
            np.array([-10.0, 10, 0]), np.zeros(3), 0, vehicle, params, v
        )
        turn = np.sqrt(2 * margin - margin**2) * limit
        np.testing.assert_allclose(
            _delivered(*setpoint[:3], 0.0, vehicle.weight),
            [-(1 - margin) * limit, turn, 0],
            atol=1e-12,
        )
    # Without braking, or without a velocity, all of F_n is scaled.
    for F_n, velocity in (([2.0, 10, 0], v), ([-2.0, 10, 0], None)):
        setpoint = attitude_setpoint(
            np.array(F_n), np.zeros(3), 0, vehicle, params, velocity
        )
        delivered = _delivered(*setpoint[:3], 0.0, vehicle.weight)
        np.testing.assert_allclose(delivered, limit * np.array(F_n) / np.hypot(2, 10))


def _binds(T, roll, pitch, T_min) -> bool:
    return T == pytest.approx(T_min) or np.hypot(roll, pitch) == pytest.approx(
        P.max_tilt
    )


@pytest.mark.parametrize("margin", [0.0, 0.1])
def test_brake_first_adds_no_work_and_respects_the_limits(margin):
    """Any F_n, v, yaw: the delivered force is s b + k q with b the braking
    part of F_n and q the rest: its part ⟂ v is parallel to F_n's (the ⟂
    terms do no work) and its part along v never exceeds F_n's; the thrust
    floor and tilt limit hold. s < 1 only where s b / (1 − δ) is on a limit
    (δ the brake margin); k < 1 only where s b + k q is."""
    vehicle = VEHICLES["drake_default"]
    params = dataclasses.replace(P, brake_first=True, brake_margin=margin)
    T_min = P.min_thrust_fraction * vehicle.weight
    rng = np.random.default_rng(3)
    for scale in (0.5, 5.0, 50.0):
        for _ in range(200):
            F_n = rng.normal(size=3) * scale * vehicle.weight / 5
            v = rng.normal(size=3)
            yaw = rng.uniform(-np.pi, np.pi)
            T, roll, pitch, _ = attitude_setpoint(
                F_n, np.array([0, 0, yaw]), 0.0, vehicle, params, v
            )
            delivered = _delivered(T, roll, pitch, yaw, vehicle.weight)
            l_v = v / np.linalg.norm(v)
            perp, perp_n = delivered - (delivered @ l_v) * l_v, F_n - (F_n @ l_v) * l_v
            np.testing.assert_allclose(np.cross(perp, perp_n), 0, atol=1e-9 * scale**2)
            assert perp @ perp_n >= -1e-12
            assert T >= T_min * (1 - 1e-12)
            assert np.hypot(roll, pitch) <= P.max_tilt * (1 + 1e-9)
            rest_in_full = np.allclose(perp, perp_n, atol=1e-9 * scale)
            if F_n @ l_v < 0:
                assert F_n @ l_v - 1e-9 <= delivered @ l_v <= 1e-12
                s = (delivered @ l_v) / (F_n @ l_v)
                if s < 1 - 1e-9:  # b scaled: s b / (1 − δ) is on a limit
                    b_s = s * (F_n @ l_v) * l_v / (1 - margin)
                    T_b, roll_b, pitch_b, _ = attitude_setpoint(
                        b_s, np.array([0, 0, yaw]), 0.0, vehicle, params
                    )
                    assert _binds(T_b, roll_b, pitch_b, T_min)
                    if rest_in_full:
                        continue
            if not np.allclose(delivered, F_n, atol=1e-9 * scale):
                assert _binds(T, roll, pitch, T_min)


@pytest.mark.parametrize("margin", [0.0, 0.1])
def test_brake_first_is_continuous_where_the_braking_alone_reaches_a_limit(margin):
    """Level, v along +x, F_n = (−B, 0, Z) with Z > 0 lifting: B just under
    and just over (1 − δ)⁻¹ m g max_tilt (where the braking is first scaled)
    give the same delivered force, (−(1 − δ) · that limit, 0, Z). It once
    dropped the lift on the far side, a 17 → 7 N thrust jump the integrator
    chattered on."""
    vehicle = VEHICLES["drake_default"]
    params = dataclasses.replace(P, brake_first=True, brake_margin=margin)
    limit = P.max_tilt * vehicle.weight
    v = np.array([1.0, 0.0, 0.0])
    for B in (limit * (1 - 1e-9), limit * (1 + 1e-9)):
        B /= 1 - margin
        setpoint = attitude_setpoint(
            np.array([-B, 0.0, 3.0]), np.zeros(3), 0, vehicle, params, v
        )
        np.testing.assert_allclose(
            _delivered(*setpoint[:3], 0.0, vehicle.weight),
            [-(1 - margin) * limit, 0.0, 3.0],
            rtol=1e-8,
        )


def test_the_brake_margin_keeps_the_turn_continuous_where_it_grazes_the_limit():
    """The tree_on_ground case, by hand: level, L = m g max_tilt. The
    braking A = (t w, 0, −t² w)/(1 + t²) (t = max_tilt, w = m g) lies on the
    tilt cone K|f_h| = t (f_z + w), and v ∝ (−1, 0, t) is ⟂ the cone's
    generator d = (t, 0, 1) through A, so the plane ⟂ v through A touches
    the cone along d. Ask for twice that braking and a turn q = d (⟂ v).
    Turning v by ±1e-7 rad about y tilts that plane to either side of d:
    with no margin the turn delivered jumps between all of d and none of it
    (the sliding surface tree_on_ground's integrator crawled along in 2 µs
    steps); with δ = 0.1 the braking stops (1 − δ) short of the limit
    and the delivered force moves by less than 1e-5 N."""
    vehicle = VEHICLES["drake_default"]
    t, w = P.max_tilt, vehicle.weight
    A = np.array([t * w, 0.0, -t * t * w]) / (1 + t * t)
    d = np.array([t, 0.0, 1.0])

    def delivered(angle, margin):
        params = dataclasses.replace(P, brake_first=True, brake_margin=margin)
        c, s = np.cos(angle), np.sin(angle)
        v = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array([-1.0, 0, t])
        l_v = v / np.linalg.norm(v)
        q = d - (d @ l_v) * l_v
        setpoint = attitude_setpoint(2 * A + q, np.zeros(3), 0, vehicle, params, v)
        return _delivered(*setpoint[:3], 0.0, w)

    jump = delivered(1e-7, 0.0) - delivered(-1e-7, 0.0)
    assert np.linalg.norm(jump) == pytest.approx(np.linalg.norm(d), rel=1e-3)
    step = delivered(1e-7, 0.1) - delivered(-1e-7, 0.1)
    assert np.linalg.norm(step) < 1e-5


@pytest.mark.parametrize("name", sorted(VEHICLES))
@pytest.mark.parametrize("force", [[0.3, 0, 0], [0, 0.3, 0], [0, -0.3, 0], [0, 0, 0.5]])
def test_commanded_force_moves_the_vehicle_that_way(name, force):
    """Open-loop in position: F_n constant, attitude PD + mixer + plant (and
    the vehicle's motor lag and "x" map, `add_rotor_path`); F_n per unit
    mass as for drake_default's 0.775 kg."""
    from pydrake.systems.analysis import Simulator

    from mfi_drake.flight.builder import add_rotor_path

    vehicle = VEHICLES[name]
    force = np.asarray(force) * vehicle.mass / 0.775
    builder = DiagramBuilder()
    plant = builder.AddSystem(make_plant(vehicle))
    source = builder.AddSystem(ConstantVectorSource(np.asarray(force, float)))
    attitude = builder.AddSystem(AttitudePD(vehicle, P))
    mixer = builder.AddSystem(RotorMixer(vehicle))
    builder.Connect(source.get_output_port(), attitude.GetInputPort("navigation_force"))
    builder.Connect(plant.get_output_port(0), attitude.GetInputPort("state"))
    builder.Connect(attitude.GetOutputPort("thrust_torque"), mixer.get_input_port())
    builder.Connect(
        mixer.GetOutputPort("propeller_force"),
        add_rotor_path(builder, vehicle, plant.get_input_port(0), True),
    )
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(1.5)
    x = plant.GetMyContextFromRoot(
        simulator.get_context()
    ).get_continuous_state_vector()
    p = np.asarray(x.CopyToVector()[:3])
    # Expected displacement of a point mass: ½ (F/m) t², less the attitude lag.
    expected = 0.5 * np.asarray(force) / vehicle.mass * 1.5**2
    axis = int(np.argmax(np.abs(force)))
    assert np.sign(p[axis]) == np.sign(force[axis])
    assert 0.5 * abs(expected[axis]) < abs(p[axis]) < 1.05 * abs(expected[axis])
    others = [i for i in range(3) if i != axis]
    assert np.all(np.abs(p[others]) < 0.05 * abs(p[axis]))
