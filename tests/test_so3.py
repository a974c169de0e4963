"""SO(3) helpers against independent oracles (Rodrigues' exponential)."""

import numpy as np
import pytest

from mfi_drake.maths.so3 import (
    bisector_turn,
    cross,
    hat,
    reference_axis,
    rotation_from_reference,
    rotation_vector,
    so3_log,
    vee,
)


def expm_so3(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula exp(angle·hat(axis)), written independently."""
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_hat_is_the_cross_product_and_vee_inverts_it():
    rng = np.random.default_rng(0)
    for _ in range(20):
        w, x = rng.normal(size=3), rng.normal(size=3)
        np.testing.assert_allclose(hat(w) @ x, np.cross(w, x), atol=1e-14)
        np.testing.assert_allclose(cross(w, x), np.cross(w, x), atol=1e-14)
        np.testing.assert_allclose(vee(hat(w)), w)


def test_eq16_rotation_maps_reference_to_target_and_is_a_rotation():
    rng = np.random.default_rng(1)
    for _ in range(50):
        r_ref, u = rng.normal(size=3), rng.normal(size=3)
        r_ref, u = r_ref / np.linalg.norm(r_ref), u / np.linalg.norm(u)
        if 1 + r_ref @ u < 1e-3:
            continue
        R = rotation_from_reference(r_ref, u)
        np.testing.assert_allclose(R @ r_ref, u, atol=1e-12)
        np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        # Literal eq 16: I + W + W² / (1 + cos φ).
        W = hat(np.cross(r_ref, u))
        np.testing.assert_allclose(
            R, np.eye(3) + W + W @ W / (1 + r_ref @ u), atol=1e-12
        )


@pytest.mark.parametrize(
    "angle", [0.0, 1e-9, 1e-4, 0.3, 1.0, 2.5, 3.0, np.pi - 1e-7, np.pi]
)
def test_log_inverts_the_exponential_at_every_angle(angle):
    rng = np.random.default_rng(int(angle * 1000))
    for _ in range(10):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        L = so3_log(expm_so3(axis, angle))
        assert np.all(np.isfinite(L))
        w = vee(L)
        if angle < np.pi - 1e-6:
            np.testing.assert_allclose(w, angle * axis, atol=1e-7)
        else:  # at π the axis sign is a free, deterministic choice
            np.testing.assert_allclose(np.abs(w @ axis), angle, atol=1e-5)
            np.testing.assert_allclose(np.linalg.norm(w), angle, atol=1e-5)


def test_reference_axis_keeps_eq16_away_from_its_singularity():
    rng = np.random.default_rng(2)
    pairs = [(np.array([1.0, 0, 0]), np.array([-1.0, 0, 0]))]
    pairs += [(np.array([0, 0, 1.0]), np.array([0, 0, -1.0]))]
    for _ in range(200):
        a, b = rng.normal(size=3), rng.normal(size=3)
        pairs.append((a / np.linalg.norm(a), b / np.linalg.norm(b)))
    for l_a, l_g in pairs:
        r_ref = reference_axis(l_a, l_g)
        assert 1 + r_ref @ l_a >= 0.3 - 1e-12
        assert 1 + r_ref @ l_g >= 0.3 - 1e-12
        assert np.linalg.norm(r_ref) == pytest.approx(1.0)


def test_bisector_turn_is_eq_17_18_with_the_bisector_reference():
    """The closed form against eq 16–18 evaluated with matrices: R_v, R_g
    from r_ref = the bisector, ω_ref = R_g (−log(R_gᵀ R_v)) (K_ω = 1)."""
    rng = np.random.default_rng(7)
    pairs = [(np.array([1.0, 0, 0]), np.array([1.0, 0, 0]))]  # aligned: 0
    pairs += [(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))]  # 90°: π/2 e_z
    for _ in range(300):
        a, b = rng.normal(size=3), rng.normal(size=3)
        pairs.append((a / np.linalg.norm(a), b / np.linalg.norm(b)))
    for l_a, l_g in pairs:
        turn = bisector_turn(l_a, l_g)
        if np.linalg.norm(l_a + l_g) <= 0.1:
            assert turn is None  # the fixed axes of reference_axis apply
            continue
        r_ref = reference_axis(l_a, l_g)
        R_v = rotation_from_reference(r_ref, l_a)
        R_g = rotation_from_reference(r_ref, l_g)
        np.testing.assert_allclose(turn, R_g @ -rotation_vector(R_g.T @ R_v), atol=1e-9)
    np.testing.assert_allclose(bisector_turn(*pairs[0]), np.zeros(3))
    np.testing.assert_allclose(bisector_turn(*pairs[1]), [0, 0, np.pi / 2])
