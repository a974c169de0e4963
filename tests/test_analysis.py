"""Issue 5: linearisation, stability, zero work and region of attraction, each
against an oracle of its own: hand-derived matrices, Routh–Hurwitz, central
finite differences, closed forms, and a system whose ROA is known."""

import json
import os

import numpy as np
import pytest
from pydrake.symbolic import Evaluate, Jacobian, Variable
from pydrake.systems.framework import InputPortIndex, OutputPortIndex
from pydrake.systems.primitives import Linearize

from mfi_drake.app.cli import main
from mfi_drake.config.parameters import REPAIRS
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.flight.analysis_diagram import build_analysis_diagram, hover_state
from mfi_drake.flight.simulation import simulate
from mfi_drake.maths import fields
from mfi_drake.maths.constants import GRAVITY
from mfi_drake.maths.layout import obstacle_signal
from mfi_drake.maths.quadcopter import attitude_gains
from mfi_drake.maths.reduced_models import (
    point_mass_heading,
    reduced_terminal_dynamics,
)
from mfi_drake.studies.analysis.cruise import cruise_report, far_goal_heading
from mfi_drake.studies.analysis.linearization import (
    finite_difference_jacobian,
    gain_sweep,
    hover_matrix,
    linearize_closed_loop,
    plant_at_hover,
    plant_report,
    with_gains,
)
from mfi_drake.studies.analysis.roa import (
    certified_quadratic,
    reduced_model_boundary,
    reduced_model_constants,
    roa_sampled,
    roa_sos,
)
from mfi_drake.systems.navigation import MfiNavigator
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

PLANAR_WALL = os.path.join(SCENARIOS, "planar_wall.yaml")
# The gains before tuning: the models checked here (the attitude loop as a
# linear lag, the heading's decay through it) hold while the tilt limit does
# not bind. The tuned gains steer late and hard, at the tilt limit near the
# wall, and their heading decays at 3.5/s against the lagged model's 6.3/s:
# past where these models apply (docs/analysis.md).
PRE_TUNING = "{c: 4.0, r_l: 1.5, c_perp: 0.2, r_b: 0.6, K_omega: 1.5}"
SCENARIO = load_scenario(PLANAR_WALL, [("gains", f"navigator: {PRE_TUNING}")])
VEHICLE = VEHICLES[SCENARIO.vehicle]
PARAMS = SCENARIO.navigator


def loop_constants():
    """m, K_Pv, k_p = K_P/m, k_d = K_D/m and per-axis a = K_Pθ/J, b = K_Dθ/J."""
    K_Ptheta, K_Dtheta = attitude_gains(VEHICLE, PARAMS)
    J = np.asarray(VEHICLE.inertia)
    m = VEHICLE.mass
    return m, PARAMS.K_Pv, PARAMS.K_P / m, PARAMS.K_D / m, K_Ptheta / J, K_Dtheta / J


def test_plant_linearisation_matches_hand_derived_A_B():
    A, B = plant_at_hover(VEHICLE)
    m, L, kF, kM = VEHICLE.mass, VEHICLE.arm_length, VEHICLE.kF, VEHICLE.kM
    J = np.asarray(VEHICLE.inertia)
    A_hand = np.zeros((12, 12))
    A_hand[0:6, 6:12] = np.eye(6)
    A_hand[6, 4] = GRAVITY  # +pitch accelerates toward +x
    A_hand[7, 3] = -GRAVITY  # +roll toward −y
    D = np.array(  # eq 8: [T, τx, τy, τz] = D u
        [
            [kF, kF, kF, kF],
            [0.0, L * kF, 0.0, -L * kF],
            [-L * kF, 0.0, L * kF, 0.0],
            [kM, -kM, kM, -kM],
        ]
    )
    B_hand = np.zeros((12, 4))
    B_hand[8] = D[0] / m
    B_hand[9:12] = D[1:4] / J[:, None]
    np.testing.assert_allclose(A, A_hand, atol=1e-12)
    np.testing.assert_allclose(B, B_hand, atol=1e-12)
    report = plant_report(VEHICLE)
    assert report["controllability_rank"] == 12
    orders = report["reach_order"]
    assert orders["x"] == orders["y"] == 3 and orders["dx"] == orders["dy"] == 2
    assert orders["dz"] == orders["droll"] == orders["dpitch"] == orders["dyaw"] == 0


def test_closed_loop_linearisation_matches_hand_derived_A():
    """Eq 20–25 linearised by hand at hover (yaw 0, tilt compensation exact
    to first order) against Drake's Linearize of the templated systems."""
    m, K, k_p, k_d, a, b = loop_constants()
    A_hand = np.zeros((12, 12))
    A_hand[0:6, 6:12] = np.eye(6)
    A_hand[6, 4], A_hand[7, 3] = GRAVITY, -GRAVITY
    A_hand[8, 2], A_hand[8, 8] = -k_p, -k_d
    # pitch_d = K F_x / (m g), roll_d = −K F_y / (m g), F = −K_P e − K_D v.
    A_hand[9, [3, 9, 1, 7]] = [
        -a[0],
        -b[0],
        a[0] * K * k_p / GRAVITY,
        a[0] * K * k_d / GRAVITY,
    ]
    A_hand[10, [4, 10, 0, 6]] = [
        -a[1],
        -b[1],
        -a[1] * K * k_p / GRAVITY,
        -a[1] * K * k_d / GRAVITY,
    ]
    A_hand[11, [5, 11]] = [-a[2], -b[2]]
    A = hover_matrix(SCENARIO)
    np.testing.assert_allclose(A, A_hand, atol=1e-9)
    assert np.linalg.eigvals(A).real.max() < 0.0


def test_linearize_agrees_with_central_differences_at_hover_and_in_cruise():
    hover = build_analysis_diagram(SCENARIO, fields.MODE_PD)
    x0 = hover_state(hover.goal)
    error = np.abs(
        linearize_closed_loop(hover, x0) - finite_difference_jacobian(hover.diagram, x0)
    ).max()
    assert error <= 1e-6
    # Cruising 40° off the goal direction, tilted and turning: eq 16–19 and
    # the mixer in AutoDiffXd, away from any equilibrium.
    cruise = build_analysis_diagram(SCENARIO, fields.MODE_CRUISE)
    x = hover_state([2.0, 1.0, 1.2])
    x[3:6] = [0.05, -0.1, 0.02]
    x[6:9] = 0.9 * np.array([np.cos(0.7), np.sin(0.7), 0.05])
    x[9:12] = [0.1, -0.2, 0.05]
    context = cruise.diagram.CreateDefaultContext()
    context.SetContinuousState(x)
    A = Linearize(cruise.diagram, context, equilibrium_check_tolerance=np.inf).A()
    A_fd = finite_difference_jacobian(cruise.diagram, x)
    assert np.abs(A - A_fd).max() <= 1e-6
    assert np.abs(A[6:9, 6:9]).max() > 0.1  # the goal fields do depend on v


def test_linearized_navigator_alone_matches_finite_differences_of_eq_11_15():
    """Linearize on one templated LeafSystem near an obstacle: ∂F_o/∂state."""
    goal = np.asarray(SCENARIO.goal, float)
    navigator = MfiNavigator(PARAMS, goal, VEHICLE.collision_radius)
    context = navigator.CreateDefaultContext()
    x = hover_state([3.0, 0.3, 1.5])
    x[6:9] = [0.8, 0.3, 0.1]
    r_o = np.array([0.9, -0.2, 0.1])  # the wall 0.9 m ahead
    state, obstacle = (
        navigator.GetInputPort("state"),
        navigator.GetInputPort("obstacle"),
    )
    state.FixValue(context, x)
    obstacle.FixValue(context, obstacle_signal([r_o]))
    D = Linearize(
        navigator,
        context,
        InputPortIndex(state.get_index()),
        OutputPortIndex(navigator.GetOutputPort("obstacle_force").get_index()),
        equilibrium_check_tolerance=np.inf,
    ).D()

    def F_o(v):
        F, F_a = fields.obstacle_field(
            v, r_o, 1.0, goal - x[0:3], VEHICLE.collision_radius, PARAMS
        )
        return F + F_a

    h = 1e-6
    for i in range(3):
        dv = np.zeros(3)
        dv[i] = h
        column = (F_o(x[6:9] + dv) - F_o(x[6:9] - dv)) / (2 * h)
        np.testing.assert_allclose(D[:, 6 + i], column, atol=1e-6)
    assert np.abs(D[:, 6:9]).max() > 0.1 and np.abs(D[:, 0:6]).max() == 0.0


def test_gain_sweep_finds_the_routh_hurwitz_boundaries():
    """One horizontal axis at hover has s⁴ + b s³ + a s² + aK k_d s + aK k_p:
    stable iff b > K k_d and a k_d (b − K k_d) > b² k_p."""
    m, K, k_p, k_d, a, b = loop_constants()
    a, b = a[1], b[1]  # roll and pitch share ω_n and ζ
    root = np.sqrt(a * a * b * b - 4.0 * K * a * b * b * k_p)
    disc = np.sqrt(a * a * k_d * k_d * b * b - 4.0 * b * b * k_p * a * K * k_d * k_d)
    expected = {
        "K_P": [(a * k_d * (b - K * k_d) / (b * b * k_p), "above")],
        "K_D": [
            ((a * b - root) / (2 * K * a) / k_d, "below"),
            ((a * b + root) / (2 * K * a) / k_d, "above"),
        ],
        "K_Ptheta": [(b * b * k_p / (a * k_d * (b - K * k_d)), "below")],
        "K_Dtheta": [
            ((a * k_d * b - disc) / (2 * b * b * k_p), "below"),
            ((a * k_d * b + disc) / (2 * b * b * k_p), "above"),
        ],
    }
    sweep = gain_sweep(SCENARIO)
    for gain, boundaries in expected.items():
        low, high = sweep[gain]["factors"][[0, -1]]
        boundaries = [(f, side) for f, side in boundaries if low < f < high]
        found = sweep[gain]["stability_lost"]
        assert [c["unstable"] for c in found] == [side for _, side in boundaries]
        for c, (factor, _) in zip(found, boundaries, strict=True):
            assert c["factor"] == pytest.approx(factor, rel=1e-6), gain
        assert np.all(sweep[gain]["max_real_part"][40] < 0)  # the default


@pytest.fixture(scope="module", params=["paper", "repaired"])
def flight(request):
    """The planar wall with both forms of MFI (the pre-tuning gains)."""
    if request.param == "repaired":
        return simulate(SCENARIO)
    paper = "{" + ", ".join(f"{r}: false" for r in REPAIRS) + "}"
    return simulate(
        load_scenario(
            PLANAR_WALL,
            [("g", f"navigator: {PRE_TUNING}"), ("p", f"navigator: {paper}")],
        )
    )


def test_zero_work_terms_do_no_work_at_field_level_but_do_through_the_lag(flight):
    report = cruise_report(flight)["report"]
    assert report["recomputed_vs_logged_max_difference"] <= 1e-12
    assert report["zero_work_field_max_abs_power"] <= 1e-9
    # The vehicle realises them through its lagging tilt: not zero...
    assert min(report["realised_power_max_abs"].values()) > 0.05
    # ...and the lag model explains the force the vehicle really applied.
    assert report["realised_model_residual_rms"] < 0.05 * report["realised_force_rms"]
    speed = report["speed"]
    assert (
        0.9 <= speed["settled_mean"] <= 1.2
        and speed["fraction_within_10_percent"] > 0.5
    )


def test_heading_of_a_point_mass_decays_as_eq_17_closed_form():
    """Far goal, start across it: β(t) = β0 exp(−K_ω t / m) for a point mass."""
    times = np.linspace(0.0, 2.0, 41)
    goal = np.array([1e4, 0.0, 0.0])
    beta = point_mass_heading(
        np.zeros(3), np.array([0.0, PARAMS.v_d, 0.0]), goal, PARAMS, 0.8, times
    )
    closed_form = (np.pi / 2) * np.exp(-PARAMS.K_omega * times / 0.8)
    np.testing.assert_allclose(beta, closed_form, atol=2e-3)


def test_vehicle_heading_decays_at_the_rate_of_the_lagged_loop():
    far = far_goal_heading(SCENARIO)
    assert far["point_mass_max_difference_to_closed_form"] < 2e-3
    assert far["vehicle_rate"] == pytest.approx(far["lagged_model_rate"], rel=0.05)


def test_region_of_attraction_certificate_of_a_known_system():
    """ẋ = −x + x³ is attracted to 0 exactly on |x| < 1."""
    x = Variable("x")
    S = certified_quadratic([x], [-x + x**3])
    boundary = 1.0 / np.sqrt(S[0, 0])
    assert 0.99 <= boundary <= 1.0 + 1e-6


def test_reduced_model_has_the_lateral_modes_of_the_full_closed_loop():
    constants = reduced_model_constants(SCENARIO)
    x = [Variable(n) for n in "evtw"]
    J = Evaluate(
        Jacobian(reduced_terminal_dynamics(x, **constants), x),
        {v: 0.0 for v in x},
    )
    full = np.linalg.eigvals(hover_matrix(SCENARIO))
    for eigenvalue in np.linalg.eigvals(J):
        assert np.abs(full - eigenvalue).min() < 1e-8


def test_sos_certificate_holds_for_the_reduced_model():
    sos = roa_sos(SCENARIO)
    assert 0.1 < sos["radius"] <= sos["radius_reduced_model"]
    S = np.asarray(sos["lyapunov_S"])
    constants = reduced_model_constants(SCENARIO)
    # V̇ = 2 xᵀ S f(x) < 0 at random points of the certified set {xᵀ S x ≤ 1}.
    rng = np.random.default_rng(1)
    y = rng.normal(size=(4, 20000))
    y *= rng.uniform(0.01, 1.0, size=20000) / np.linalg.norm(y, axis=0)
    x = np.linalg.solve(np.linalg.cholesky(S).T, y)  # xᵀ S x = |y|²
    f = np.array(reduced_terminal_dynamics(x, **constants))
    assert np.all(np.einsum("ik,ij,jk->k", x, S, f) < 0.0)
    # Every start on the certified ball converges.
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    largest = sos["radius_reduced_model"]
    boundary = reduced_model_boundary(SCENARIO, angles, largest=largest)
    assert np.all(boundary == largest)
    # On the part quoted for the vehicle, no saturation is active.
    rho = sos["rho_without_saturation"]
    assert rho * np.linalg.inv(S)[2, 2] <= PARAMS.max_tilt**2 + 1e-12


def test_sampled_region_of_attraction_detects_divergence():
    unstable, attitude_K = with_gains(SCENARIO, {"K_D": 0.05})
    assert roa_sampled(unstable, np.array([0.1]), np.eye(6)[:1])["radius"] == 0
    stable = roa_sampled(SCENARIO, np.array([0.5, 2.0]), np.eye(6)[[0, 3]])
    assert stable["radius"] == 2.0 and stable["lower_bound_only"]


def test_analyze_command_prints_the_report_as_json(tmp_path, capsys):
    assert main(["analyze", PLANAR_WALL, "--out", str(tmp_path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["max_real_part"] < 0
    assert report["linearize_vs_fd_max_error"] <= 1e-6
    assert report["controllability_rank"] == 12
    assert report["zero_work_field_max_abs_power"] <= 1e-9
    assert len(report["hover_eigenvalues"]) == 12
    for key in ("roa_sos", "roa_sampled"):
        assert (
            report[key]["radius"] > 0 and report[key]["units"] and report[key]["model"]
        )
    for name in ("eigenvalues", "power", "heading", "roa"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    assert json.loads((tmp_path / "analysis.json").read_text()) == report


def test_analyze_rejects_a_missing_scenario(capsys):
    assert main(["analyze", "no/such.yaml"]) == 2
    assert "no/such.yaml: no such file" in capsys.readouterr().err


def test_a_flight_too_short_to_settle_in_cruise_reports_no_settled_speed():
    from mfi_drake.studies.analysis.cruise import speed_report

    t = np.array([0.0, 1.0, 2.0, 3.0])
    speed = np.array([0.1, 0.2, 0.3, 0.4])  # never 0.9 v_d
    cruise = np.array([False, True, True, True])
    report = speed_report(t, speed, cruise, v_d=1.0)
    assert report == {"v_d": 1.0, "cruise_time": 2.0}
    speed[3] = 0.95  # settles at the last sample: its dt is 0, still unsettled
    assert "settled_mean" not in speed_report(t, speed, cruise, v_d=1.0)
    speed[2] = 1.0  # settled for the last second
    settled = speed_report(t, speed, cruise, v_d=1.0)
    assert settled["settled_mean"] == pytest.approx(1.0)
    assert settled["fraction_within_10_percent"] == pytest.approx(1.0)
