"""`mfi_drake.adapters.rotorpy` against rotorpy's own code: the control dict
has the keys of rotorpy's SE3Control, its rotor thrusts give the chain's
thrust and torques through rotorpy's own allocation matrix (so the rotor
order and spins match), the state conversion inverts rotorpy's quaternion
and body rates, and each block's closest point is rotorpy's. The flight
itself: examples/rotorpy_crazyflie.py (tests/test_examples.py)."""

import numpy as np
import pytest
from pydrake.math import RollPitchYaw

pytest.importorskip("rotorpy")

from rotorpy.controllers.quadrotor_control import SE3Control  # noqa: E402
from rotorpy.vehicles.crazyflie_params import quad_params as crazyflie  # noqa: E402
from rotorpy.vehicles.hummingbird_params import quad_params as hummingbird  # noqa: E402
from rotorpy.world import World  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from mfi_drake.adapters.rotorpy import (  # noqa: E402
    RotorpyController,
    plant_state,
    vehicle_from_quad_params,
)
from mfi_drake.config.vehicles import VEHICLES  # noqa: E402

WORLD = {
    "bounds": {"extents": [-2.0, 5.0, -2.0, 2.0, 0.0, 3.0]},
    "blocks": [
        {"extents": [1.0, 1.5, -0.5, 0.5, 0.0, 3.0], "color": [1, 0, 0]},
        {"extents": [2.5, 3.0, 0.5, 1.0, 0.0, 3.0], "color": [1, 0, 0]},
    ],
}


def state(rpy, body_rates, x=(0.0, 0.1, 1.0), v=(0.3, -0.1, 0.05)) -> dict:
    q = Rotation.from_euler("xyz", rpy).as_quat()  # R = Rz Ry Rx, [i, j, k, w]
    return {
        "x": np.array(x),
        "v": np.array(v),
        "q": q,
        "w": np.array(body_rates),
        "wind": np.zeros(3),
        "rotor_speeds": np.zeros(4),
    }


@pytest.mark.parametrize("params", [crazyflie, hummingbird], ids=["cf", "hb"])
def test_control_dict_is_rotorpys_and_its_thrusts_give_the_chains_wrench(params):
    controller = RotorpyController([4.0, 0.0, 1.0], World(WORLD), params)
    s = state([0.1, -0.05, 0.3], [0.2, -0.1, 0.05])
    got = controller.update(0.0, s, {})
    flat = {
        "x": np.zeros(3),
        "x_dot": np.zeros(3),
        "x_ddot": np.zeros(3),
        "x_dddot": np.zeros(3),
        "yaw": 0.0,
        "yaw_dot": 0.0,
    }
    theirs = SE3Control(params).update(0.0, s, flat)
    assert set(got) == set(theirs)
    for key, value in theirs.items():
        assert np.shape(got[key]) == np.shape(value), key
    # rotorpy's allocation of its own rotors, applied to our rotor thrusts.
    f_to_TM = SE3Control(params).f_to_TM
    np.testing.assert_allclose(
        f_to_TM @ got["cmd_motor_thrusts"],
        np.concatenate([[got["cmd_thrust"]], got["cmd_moment"]]),
        rtol=1e-9,
        atol=1e-12,
    )
    assert np.all(got["cmd_motor_speeds"] <= params["rotor_speed_max"] * (1 + 1e-12))


def test_vehicle_of_rotorpys_crazyflie_is_the_preset():
    """Built from rotorpy's own file, it is the crazyflie preset (whose
    numbers were copied from that file) but for the propeller radius,
    which rotorpy does not give (half the arm, against Bitcraze's 2.25 cm)."""
    built = vehicle_from_quad_params(crazyflie)
    preset = VEHICLES["crazyflie"]
    for name in ("mass", "kF", "kM", "u_max", "motor_time_constant", "layout"):
        assert getattr(built, name) == pytest.approx(getattr(preset, name)), name
    assert built.arm_length == pytest.approx(preset.arm_length, rel=1e-9)
    assert built.inertia == pytest.approx(preset.inertia)


def test_state_conversion_inverts_rotorpys_attitude_and_rates():
    rpy = np.array([0.2, -0.3, 1.1])
    rates = np.array([0.4, -0.2, 0.7])
    x = plant_state(state(rpy, rates))
    np.testing.assert_allclose(x[3:6], rpy, atol=1e-12)
    # The body rates back from the Euler rates (Drake's kinematics).
    back = RollPitchYaw(x[3:6]).CalcAngularVelocityInChildFromRpyDt(x[9:12])
    np.testing.assert_allclose(back, rates, atol=1e-12)


def test_closest_points_are_rotorpys_block_by_block():
    controller = RotorpyController([4.0, 0.0, 1.0], World(WORLD), crazyflie)
    p = np.array([2.0, 0.2, 1.0])
    points = controller.closest_points(p)
    assert points.shape == (2 + 6, 3)  # the blocks, then the bounds' faces
    np.testing.assert_allclose(points[0], [1.5, 0.2, 1.0])
    np.testing.assert_allclose(points[1], [2.5, 0.5, 1.0])
    # The nearest block's is what rotorpy's whole World answers.
    nearest, _ = World(WORLD).closest_points(p[None])
    d = np.linalg.norm(points[:2] - p, axis=1)
    np.testing.assert_allclose(points[np.argmin(d)], nearest[0])
    # Each face's point is as far as rotorpy's distance to its bounds says.
    faces = np.linalg.norm(points[2:] - p, axis=1)
    assert faces.min() == pytest.approx(World(WORLD).min_dist_boundary(p[None])[0])
    np.testing.assert_allclose(faces, [4.0, 3.0, 2.2, 1.8, 1.0, 2.0])
