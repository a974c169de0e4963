"""Gains that follow the vehicle (docs/vehicles.md, "The scaling law").

The defaults of `NavigatorParams`, the baselines' and the escape rule's
were tuned on the two shipped vehicles (`REFERENCE`), and hold as tuned for
any vehicle inside the band those two span, in mass and in collision
radius: they fly exactly as before. Outside the band a vehicle gets the
gains of dynamic similarity with the band's nearer edge:

- lengths scale by λ = R / R_band (R the collision radius): the ranges of
  the fields and of the goal zone are then the same in collision radii;
- masses by μ = m / m_band: forces are per unit mass;
- times by t = ω_ref / ω_n, the attitude loop's period relative to the
  reference's. ω_n = ω_ref / √λ (Froude: with gravity fixed, time goes
  with √length, and a vehicle's angular authority L F_max / I ∝ g T/W / L
  allows just that), lowered where the vehicle's angular authority α
  cannot turn a max_tilt step at ω_n (ω_n² max_tilt ≤ α) or its motors lag
  (ω_n ≤ 2ζ / (3 τ_m), a third of the PD loop's stability bound with a
  first-order motor lag τ_m).

A gain of units kg^a m^b s^c then scales by μ^a λ^b t^c: speeds λ/t,
accelerations λ/t² (1 under Froude: the tilt the vehicle needs is the
reference's), forces μ λ/t². The tilt limit is lowered where the thrust
to weight T/W cannot hold the weight at it with 10 % to spare for the
torques: cos max_tilt ≥ 1 / (0.9 T/W).
"""

import dataclasses
import math

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicles import VEHICLES, Vehicle

REFERENCE = ("drake_default", "pelican")  # the vehicles the defaults fit

# Units (kg, m, s) exponents of each scaled gain, by field name; every other
# field is dimensionless (or a switch) and stays. Names absent from a
# parameter class are skipped.
_FORCE = (1, 1, -2)
UNITS = {
    # MFI (NavigatorParams), eq 12–21
    "c": (1, 1, -1),  # N·s
    "r_l": (0, 1, 0),
    "c_perp": (1, 4, -2),  # N·m³
    "r_b": (0, 1, 0),
    "min_distance": (0, 1, 0),
    "fade_speed": (0, 1, -1),
    "K_omega": (1, 0, -1),  # kg/s
    "K_v": (1, 0, -1),  # N·s/m
    "v_d": (0, 1, -1),
    "K_P": (1, 0, -2),  # N/m
    "K_D": (1, 0, -1),
    "max_pd_force": _FORCE,
    "r_gl": (0, 1, 0),
    "goal_hysteresis": (0, 1, 0),
    "v_min": (0, 1, -1),
    "v_stop": (0, 1, -1),
    # the baselines (ApfParams, GfParams, AttractionParams)
    "eta": (1, 4, -2),  # N·m³
    "rho_0": (0, 1, 0),
    "k_g": (1, 1, -1),  # N·s
    "r_d": (0, 1, 0),
    "k_att": (1, 0, -2),
    "k_d": (1, 0, -1),
    "v_max": (0, 1, -1),
    # the escape rule (EscapeParams)
    "stall_time": (0, 0, 1),
    "progress": (0, 1, 0),
    "follow_distance": (0, 1, 0),
    "hug": (0, -1, 0),
    "lookahead": (0, 1, 0),
    "leave_margin": (0, 1, 0),
    "loop_radius": (0, 1, 0),
    "revisit_radius": (0, 1, 0),
}


def _band(value: float, values: list[float]) -> float:
    return value / min(max(value, min(values)), max(values))


def angular_authority(vehicle: Vehicle) -> float:
    """α: the roll or pitch acceleration of one rotor at full thrust on its
    arm [rad/s²] (two rotors on the lever L/√2 each for the "x" layout)."""
    lever = vehicle.arm_length * (math.sqrt(2.0) if vehicle.layout == "x" else 1.0)
    return lever * vehicle.kF * vehicle.u_max / max(vehicle.inertia[:2])


def tilt_limit(vehicle: Vehicle, max_tilt: float) -> float:
    """max_tilt, lowered to where full thrust holds the weight with 10 % to
    spare: cos θ = 1 / (0.9 T/W)."""
    return min(max_tilt, math.acos(min(1.0, 1.0 / (0.9 * vehicle.thrust_to_weight))))


def attitude_frequency(vehicle: Vehicle, frequency: float, damping: float, tilt: float):
    """ω_n of the attitude loops for `vehicle`, from the reference's
    `frequency` (the module's docstring)."""
    radii = [VEHICLES[n].collision_radius for n in REFERENCE]
    omega = frequency / math.sqrt(_band(vehicle.collision_radius, radii))
    omega = min(omega, math.sqrt(angular_authority(vehicle) / tilt))
    if vehicle.motor_time_constant > 0.0:
        omega = min(omega, 2.0 * damping / (3.0 * vehicle.motor_time_constant))
    return omega


def scales(vehicle: Vehicle, params) -> tuple[float, float, float]:
    """(μ, λ, t): mass, length and time scales of `vehicle` against the
    reference band, the time from `params`' attitude loop (a
    NavigatorParams; the defaults' for any other)."""
    if not isinstance(params, NavigatorParams):
        params = NavigatorParams()
    masses = [VEHICLES[n].mass for n in REFERENCE]
    radii = [VEHICLES[n].collision_radius for n in REFERENCE]
    w = params.attitude_natural_frequency
    tilt = tilt_limit(vehicle, params.max_tilt)
    omega = attitude_frequency(vehicle, w, params.attitude_damping_ratio, tilt)
    return (
        _band(vehicle.mass, masses),
        _band(vehicle.collision_radius, radii),
        w / omega,
    )


def for_vehicle(params, vehicle: Vehicle, attitude=None):
    """`params` (NavigatorParams, ApfParams, GfParams, EscapeParams, or a
    nested dataclass of them) with every gain of `UNITS` scaled for
    `vehicle`, and a NavigatorParams' tilt limit and attitude frequency
    its own; `params` itself where nothing changes (a vehicle in the
    reference band). `attitude`: the NavigatorParams whose attitude loop
    sets the time scale (default `params` if it is one)."""
    mu, lam, t = scales(vehicle, attitude if attitude is not None else params)
    tilt = getattr(params, "max_tilt", None)
    same_tilt = tilt is None or tilt_limit(vehicle, tilt) == tilt
    if (mu, lam, t) == (1.0, 1.0, 1.0) and same_tilt:
        return params
    return _scaled(params, vehicle, mu, lam, t)


def _scaled(params, vehicle: Vehicle, mu: float, lam: float, t: float):
    changes = {}
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        if dataclasses.is_dataclass(value):
            changes[f.name] = _scaled(value, vehicle, mu, lam, t)
        elif f.name in UNITS and not isinstance(value, bool):
            a, b, c = UNITS[f.name]
            changes[f.name] = value * mu**a * lam**b * t**c
    if hasattr(params, "attitude_natural_frequency"):
        tilt = tilt_limit(vehicle, params.max_tilt)
        changes["max_tilt"] = tilt
        changes["attitude_natural_frequency"] = params.attitude_natural_frequency / t
    return dataclasses.replace(params, **changes)


def similar_scenario(scenario, vehicle: Vehicle):
    """`scenario` as the scene similar to it for `vehicle` (a Scenario
    written for the reference band, e.g. the paper's): every length (start,
    goal, obstacles, sphere sensor, goal tolerance, ground) scaled by λ and
    the duration by t (`scales`), flown by `vehicle`; a convex shape by its
    `scale`. A check of the law: the vehicle should fly it as the reference
    flies `scenario` (tests/test_vehicle_family.py)."""
    _, lam, t = scales(vehicle, scenario.navigator)
    obstacles = [
        dataclasses.replace(
            o,
            shape=_scaled_shape(o.shape, lam),
            position=[lam * x for x in o.position],
        )
        for o in scenario.obstacles
    ]
    changes = {}
    if hasattr(scenario.sensor, "radius"):
        changes["sensor"] = dataclasses.replace(
            scenario.sensor, radius=lam * scenario.sensor.radius
        )
    if scenario.ground is not None:
        changes["ground"] = dataclasses.replace(
            scenario.ground, height=lam * scenario.ground.height
        )
    return dataclasses.replace(
        scenario,
        vehicle=vehicle,
        start=[lam * x for x in scenario.start],
        goal=[lam * x for x in scenario.goal],
        obstacles=obstacles,
        goal_tolerance=lam * scenario.goal_tolerance,
        duration=t * scenario.duration,
        **changes,
    )


def _scaled_shape(shape, lam: float):
    changes = {}
    for f in dataclasses.fields(shape):
        value = getattr(shape, f.name)
        if f.name == "vertices":  # `scale` scales them too
            continue
        if f.name in ("scale", "radius", "length"):
            changes[f.name] = lam * value
        elif isinstance(value, list):  # Box.size, Ellipsoid.radii
            changes[f.name] = [lam * x for x in value]
    return dataclasses.replace(shape, **changes)
