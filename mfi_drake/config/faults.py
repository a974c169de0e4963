"""The scenario's `faults:` block: faults and imperfections of a real
vehicle, each off by default (the systems that model them are in
`systems.faults`, their maths in `maths.faults`)."""

import math
from dataclasses import dataclass, fields

from mfi_drake.maths.layout import ROTORS

MAX_DELAY_SAMPLES = 1000  # longest delay line sensor_latency may ask for


@dataclass
class Faults:
    """The scenario's `faults:` block; every default means "no such fault"."""

    sample_rate: float = 50.0
    """Rate at which the sensor faults and the state-estimate error draw a
    new sample and hold it [Hz]."""
    seed: int = 0
    """Seed of every random fault; the same seed gives the same flight [-]."""
    sensor_noise_std: float = 0.0
    """Std of the Gaussian noise on each component of r_o while an obstacle
    is seen [m]."""
    dropout_prob: float = 0.0
    """Probability that a sample is lost; for that sample period the
    navigator is told "nothing seen" (r_o = 0, seen = 0), the reading a real
    range sensor gives when it has no return [-]."""
    sensor_latency: float = 0.0
    """Delay of the obstacle reading, rounded to whole sample periods, on top
    of the sample-and-hold [s]."""
    motor_time_constant: float = 0.0
    """Time constant of first-order rotor dynamics while a rotor spins up;
    0 = no lag (RotorS' Pelican: 0.0125) [s]."""
    motor_time_constant_down: float = 0.0
    """The same while a rotor spins down; 0 = motor_time_constant (RotorS'
    Pelican: 0.025) [s]."""
    weak_rotor: int = 0
    """Index (0–3, QuadrotorPlant's order) of the rotor weak_rotor_fraction
    applies to [-]."""
    weak_rotor_fraction: float = 1.0
    """Fraction of its commanded thrust the weak rotor delivers; 1 = healthy,
    0 = dead [-]."""
    position_noise_std: float = 0.0
    """Std of the Gaussian error on each component of the position the
    controller sees [m]."""
    velocity_noise_std: float = 0.0
    """Std of the Gaussian error on each component of the velocity the
    controller sees [m/s]."""


def fault_problems(faults: Faults) -> list[tuple[str, object, str]]:
    """Problems with `faults` as (field, value, reason) triples; [] if none."""
    problems = []
    for f in fields(faults):
        value = getattr(faults, f.name)
        if f.type is int:
            if not isinstance(value, int) or isinstance(value, bool):
                problems.append((f.name, value, "must be an integer"))
        elif (
            not isinstance(value, int | float)
            or isinstance(value, bool)
            or not math.isfinite(value)
        ):
            problems.append((f.name, value, "must be a finite number"))
        elif value < 0.0:
            problems.append((f.name, value, "must be >= 0"))
    if problems:
        return problems
    if faults.sample_rate <= 0.0:
        problems.append(("sample_rate", faults.sample_rate, "must be > 0"))
    elif delay_samples(faults) > MAX_DELAY_SAMPLES:
        problems.append(
            (
                "sensor_latency",
                faults.sensor_latency,
                f"must be at most {MAX_DELAY_SAMPLES} sample periods "
                f"({MAX_DELAY_SAMPLES / faults.sample_rate:g} s at sample_rate)",
            )
        )
    if faults.seed < 0:
        problems.append(("seed", faults.seed, "must be >= 0"))
    if faults.dropout_prob > 1.0:
        problems.append(("dropout_prob", faults.dropout_prob, "must be <= 1"))
    if faults.motor_time_constant_down > 0.0 and faults.motor_time_constant == 0.0:
        problems.append(
            (
                "motor_time_constant_down",
                faults.motor_time_constant_down,
                "needs motor_time_constant > 0",
            )
        )
    if faults.weak_rotor >= ROTORS:
        problems.append(("weak_rotor", faults.weak_rotor, "must be 0, 1, 2 or 3"))
    if faults.weak_rotor_fraction > 1.0:
        problems.append(
            ("weak_rotor_fraction", faults.weak_rotor_fraction, "must be <= 1")
        )
    return problems


def delay_samples(faults: Faults) -> int:
    """sensor_latency in whole sample periods."""
    return round(faults.sensor_latency * faults.sample_rate)
