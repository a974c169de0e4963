"""The family test (docs/vehicles.md, "Family test"): random quadrotors from
30 g to 5 kg, with the gains `config.vehicle_gains` gives them and no hand
tuning, fly the paper's four scenes and a random field each, scaled to the
vehicle (`similar_scenario`), without a collision; and each is linearised
at hover with every eigenvalue in the left half-plane.

Three vehicles, seeded, keep CI short (15 flights of 1–5 s, one test a
flight; benchmarks/vehicle_family.py flies more): their masses are drawn
log-uniformly at both ends and in the middle of [30 g, 5 kg] (`ENDS`); the
hover test's eight in eight equal slices of it. The other quantities are
drawn as real vehicles have them:
arm ∝ m^(1/3) within ±25 % (drake_default 0.15 m at 0.775 kg, the
Crazyflie 0.043 m at 30 g, the X500 0.25 m at 2 kg), clipped to
[0.04, 0.5] m; propeller radius 0.4–0.65 of the arm; roll and pitch
moments k m L² with k in [0.08, 0.28] (the presets span 0.09–0.26), yaw
0.85–1 of their sum; thrust to weight 1.5–4; a motor lag up to 40 ms;
the layouts "+" and "x" in turn.

The flights are similar to drake_default's through the same scenes (the
law's claim, docs/vehicles.md): each path, in the vehicle's lengths λ, is
within 6 % of drake_default's (measured: within 3 %)."""

import functools
import os

import numpy as np
import pytest

from mfi_drake import load_scenario, simulate
from mfi_drake.config.vehicle_gains import scales, similar_scenario
from mfi_drake.config.vehicles import Vehicle, as_vehicle
from mfi_drake.maths.constants import GRAVITY
from mfi_drake.studies.analysis.linearization import hover_matrix
from mfi_drake.world.generator import random_field

from .conftest import SCENARIOS

PAPER_SCENES = ("planar_wall", "three_spheres", "tree", "sharp_corner")
MASSES = (0.03, 5.0)  # kg
ENDS = ((0.03, 0.06), (0.2, 1.0), (2.5, 5.0))  # kg, the flown vehicles' masses
FIELD_SEED, FIELD_DENSITY = 7, 0.1  # random fields: vehicle k flies index k


def random_vehicle(
    rng: np.random.Generator, mass: float, name: str, layout: str
) -> Vehicle:
    """A quadrotor of `mass` and rotor `layout`, its other quantities drawn
    as the module's docstring says."""
    arm = 0.165 * mass ** (1 / 3) * np.exp(rng.uniform(-0.25, 0.25))
    arm = float(np.clip(arm, 0.04, 0.5))
    roll = rng.uniform(0.08, 0.28) * mass * arm**2
    pitch = roll * rng.uniform(0.9, 1.1)
    thrust_to_weight = rng.uniform(1.5, 4.0)
    return as_vehicle(
        Vehicle(
            name=name,
            mass=mass,
            arm_length=arm,
            inertia=[roll, pitch, (roll + pitch) * rng.uniform(0.85, 1.0)],
            kF=1.0,  # u in newtons
            kM=rng.uniform(0.01, 0.03),
            u_max=thrust_to_weight * mass * GRAVITY / 4.0,
            rotor_radius=arm * rng.uniform(0.4, 0.65),
            motor_time_constant=rng.uniform(0.0, 0.04),
            layout=layout,
        )
    )


def family(seed: int, slices) -> list[Vehicle]:
    """A vehicle a mass range of `slices` ((low, high) kg), its mass drawn
    log-uniformly in it; or `slices` equal slices of log [30 g, 5 kg]."""
    if isinstance(slices, int):
        edges = np.exp(np.linspace(*np.log(MASSES), slices + 1))
        slices = list(zip(edges[:-1], edges[1:], strict=True))
    rng = np.random.default_rng(seed)
    return [
        random_vehicle(
            rng,
            float(np.exp(rng.uniform(*np.log([lo, hi])))),
            f"family_{seed}_{k}",
            "+x"[k % 2],
        )
        for k, (lo, hi) in enumerate(slices)
    ]


VEHICLES = family(51, ENDS)


def written(scene: int, field: int = 0):
    """Scene `scene` as written: the paper's four, then random field `field`."""
    if scene < len(PAPER_SCENES):
        return load_scenario(os.path.join(SCENARIOS, f"{PAPER_SCENES[scene]}.yaml"))
    return random_field(FIELD_SEED, field, FIELD_DENSITY)


@pytest.mark.parametrize("scene", range(len(PAPER_SCENES) + 1))
@pytest.mark.parametrize("vehicle", VEHICLES, ids=lambda v: f"{v.mass:.3g}kg")
def test_family_flies_every_scene_without_a_collision(vehicle, scene):
    field = next(k for k, v in enumerate(VEHICLES) if v is vehicle)
    scenario = similar_scenario(written(scene, field), vehicle)
    flight = simulate(scenario, "mfi", until_settled=True)
    m = flight.metrics
    assert m["reached"], (scenario.name, vehicle, m["outcome"])
    assert m["min_clearance"] > 0.0, (scenario.name, vehicle)
    _, lam, _ = scales(vehicle, scenario.navigator)
    reference = reference_path_length(scene, field)
    assert m["path_length"] / lam == pytest.approx(reference, rel=0.06)


@functools.cache
def reference_path_length(scene: int, field: int) -> float:
    """drake_default's path through the scene as written [m]."""
    flight = simulate(written(scene, field), "mfi", until_settled=True)
    return flight.metrics["path_length"]


@pytest.mark.parametrize("vehicle", family(52, 8), ids=lambda v: f"{v.mass:.3g}kg")
def test_family_hovers_stably(vehicle):
    """The closed loop linearised at hover (PD mode, nothing seen, the
    motors' lag included): every eigenvalue in the left half-plane."""
    from mfi_drake.config.scenario import Scenario

    A = hover_matrix(Scenario(goal=[1.0, 0.0, 1.5], vehicle=vehicle))
    assert np.linalg.eigvals(A).real.max() < 0.0


def test_draws_span_the_family():
    """The drawn family holds both ends of the mass range, and each draw
    keeps to the stated bounds."""
    drawn = VEHICLES + family(52, 8)
    masses = [v.mass for v in drawn]
    assert min(masses) < 0.06 and max(masses) > 2.5
    for v in drawn:
        assert 0.03 <= v.mass <= 5.0 and 0.04 <= v.arm_length <= 0.5
        assert 1.5 <= v.thrust_to_weight <= 4.0
