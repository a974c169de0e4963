"""The fault models as plain numpy functions (see `config.faults` for the
settings and `systems.faults` for the systems that apply them).

Random faults are sampled at a fixed rate and held between samples; sample
k of a stream is drawn from a generator seeded by (seed, stream, k), so a
flight is a pure function of its scenario.
"""

import numpy as np

from mfi_drake.maths.layout import READING_SIZE, STATE_SIZE

SENSOR_STREAM = 0
ESTIMATE_STREAM = 1


def sample_index(time, rate: float) -> int:
    """k of the sample taken at `time` (float or AutoDiffXd) = k / rate."""
    return round(float(time.value() if hasattr(time, "value") else time) * rate)


def sample_rng(seed: int, stream: int, k: int) -> np.random.Generator:
    """The generator of sample k of random stream `stream` (counter-based:
    it depends on nothing but its three arguments)."""
    return np.random.default_rng([seed, stream, k])


def corrupt_reading(
    reading: np.ndarray,
    rng: np.random.Generator,
    noise_std: float,
    dropout_prob: float,
) -> np.ndarray:
    """One sensor sample (readings [r_o, seen], see `layout`) as the
    navigator receives it: lost with probability dropout_prob (then all
    zeros, "nothing seen"), else each seen r_o plus Gaussian noise of std
    noise_std [m] per component."""
    lost = rng.random() < dropout_prob
    out = np.array(reading)
    noise = noise_std * rng.standard_normal((len(out) // READING_SIZE, 3))
    if lost:
        return 0.0 * out
    for i, n in enumerate(noise):
        at = READING_SIZE * i
        if out[at + 3] > 0.5:
            out[at : at + 3] = out[at : at + 3] + n
    return out


def estimate_error(
    rng: np.random.Generator, position_std: float, velocity_std: float
) -> np.ndarray:
    """The error added to the 12-state the controller sees: Gaussian on
    position [m] and velocity [m/s], none on attitude and its rates (the
    attitude loop is assumed to have its own IMU)."""
    error = np.zeros(STATE_SIZE)
    error[0:3] = position_std * rng.standard_normal(3)
    error[6:9] = velocity_std * rng.standard_normal(3)
    return error


def rotor_lag_rate(
    command: np.ndarray, actual: np.ndarray, tau_up: float, tau_down: float
) -> np.ndarray:
    """du/dt of first-order rotors: (u_cmd − u)/τ with τ = tau_up while a
    rotor spins up (u_cmd > u), else tau_down [s]. The rate is continuous at
    the switch (it is zero there).

    The lag acts on the rotor command u (a thrust for drake_default, ω² for
    the Pelican); RotorS lags ω, which about hover is the same first-order
    response (δ(ω²) = 2ω δω).
    """
    return np.array(
        [
            (c - u) / (tau_up if c > u else tau_down)
            for c, u in zip(command, actual, strict=True)
        ]
    )
