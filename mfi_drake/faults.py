"""Faults and imperfections of a real vehicle, each off by default.

A scenario's optional `faults:` block (the `Faults` dataclass below) turns
them on; `build_diagram` then inserts the matching systems, and with no
faults the diagram is exactly the ideal one:

    plant ──state──▶ StateEstimateError ──estimate──▶ navigator, selector, attitude
    sensor ──obstacle──▶ SensorFaults ──obstacle──▶ navigator
    mixer ──u──▶ MotorLag ──▶ weak rotor (Gain) ──▶ plant

The sensor itself and the log keep the true state: the sensor is on the
vehicle and measures the obstacle relative to where the vehicle really is,
and the log records what the plant really did.

Random faults are sampled at the fixed rate `sample_rate` and held in
discrete state between samples (the integrator evaluates outputs many times
a step, so drawing per evaluation would make noise depend on the step
size). Sample k of a stream is drawn from a generator seeded by
(seed, stream, k), so a flight is a pure function of its scenario.
"""

import math
import zlib
from dataclasses import dataclass, fields, replace

import numpy as np
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.framework import BasicVector_, DiagramBuilder, LeafSystem_
from pydrake.systems.primitives import Gain
from pydrake.systems.scalar_conversion import TemplateSystem

STATE_SIZE = 12  # QuadrotorPlant's state
ROTORS = 4
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


# --- the fault models as plain numpy functions -------------------------------
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
    """One sensor sample (readings [r_o, seen], see `sensing`) as the
    navigator receives it: lost with probability dropout_prob (then all
    zeros, "nothing seen"), else each seen r_o plus Gaussian noise of std
    noise_std [m] per component."""
    lost = rng.random() < dropout_prob
    out = np.array(reading)
    noise = noise_std * rng.standard_normal((len(out) // 4, 3))
    if lost:
        return 0.0 * out
    for i, n in enumerate(noise):
        if out[4 * i + 3] > 0.5:
            out[4 * i : 4 * i + 3] = out[4 * i : 4 * i + 3] + n
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


# --- the fault systems -------------------------------------------------------
@TemplateSystem.define("SensorFaults_")
def SensorFaults_(T):
    class Impl(LeafSystem_[T]):
        """Noise, dropouts and latency of the obstacle reading.

        Every 1/sample_rate s the reading is sampled, corrupted by
        `corrupt_reading` and pushed into a delay line of delay_samples + 1
        samples held in discrete state; the output is the oldest sample
        ("nothing seen" until the first sample has come through).

        Input: "obstacle" (true; `size` values, see `sensing`).
        Output: "obstacle" (corrupted).
        """

        def _construct(self, faults: Faults, size: int, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.faults = faults
            self.size = size
            self._input = self.DeclareVectorInputPort("obstacle", size)
            self.DeclareDiscreteState((delay_samples(faults) + 1) * size)
            self.DeclarePeriodicDiscreteUpdateEvent(
                1.0 / faults.sample_rate, 0.0, self._sample
            )
            self.DeclareVectorOutputPort(
                "obstacle",
                size,
                lambda context, out: out.SetFromVector(
                    context.get_discrete_state_vector().CopyToVector()[:size]
                ),
                prerequisites_of_calc={self.xd_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.faults, other.size, converter=converter)

        def _sample(self, context, discrete_state):
            f = self.faults
            k = sample_index(context.get_time(), f.sample_rate)
            reading = corrupt_reading(
                self._input.Eval(context),
                sample_rng(f.seed, SENSOR_STREAM, k),
                f.sensor_noise_std,
                f.dropout_prob,
            )
            line = context.get_discrete_state_vector().CopyToVector()
            discrete_state.get_mutable_vector().SetFromVector(
                np.concatenate([line[self.size :], reading])
            )

    return Impl


SensorFaults = SensorFaults_[None]


@TemplateSystem.define("StateEstimateError_")
def StateEstimateError_(T):
    class Impl(LeafSystem_[T]):
        """The state the controller sees: the true state plus an
        `estimate_error` drawn every 1/sample_rate s and held (zero before
        the first draw).

        Input: "state" (12, true). Output: "estimate" (12).
        """

        def _construct(self, faults: Faults, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.faults = faults
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            self.DeclareDiscreteState(STATE_SIZE)
            self.DeclarePeriodicDiscreteUpdateEvent(
                1.0 / faults.sample_rate, 0.0, self._sample
            )
            self.DeclareVectorOutputPort(
                "estimate",
                STATE_SIZE,
                lambda context, out: out.SetFromVector(
                    self._state.Eval(context)
                    + context.get_discrete_state_vector().CopyToVector()
                ),
                prerequisites_of_calc={self._state.ticket(), self.xd_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.faults, converter=converter)

        def _sample(self, context, discrete_state):
            f = self.faults
            k = sample_index(context.get_time(), f.sample_rate)
            error = estimate_error(
                sample_rng(f.seed, ESTIMATE_STREAM, k),
                f.position_noise_std,
                f.velocity_noise_std,
            )
            discrete_state.get_mutable_vector().SetFromVector(error)

    return Impl


StateEstimateError = StateEstimateError_[None]


@TemplateSystem.define("MotorLag_")
def MotorLag_(T):
    class Impl(LeafSystem_[T]):
        """First-order rotors (`rotor_lag_rate`) between mixer and plant; the
        state u (4) starts at `initial` (the hover command, so a flight that
        starts at rest starts in equilibrium).

        Input: "command" u_cmd (4). Output: "propeller_force" u (4).
        """

        def _construct(self, tau_up, tau_down, initial, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.tau_up, self.tau_down = float(tau_up), float(tau_down)
            self.initial = np.asarray(initial, dtype=float)
            self._command = self.DeclareVectorInputPort("command", ROTORS)
            self.DeclareContinuousState(BasicVector_[T](self.initial))
            self.DeclareVectorOutputPort(
                "propeller_force",
                ROTORS,
                lambda context, out: out.SetFromVector(
                    context.get_continuous_state_vector().CopyToVector()
                ),
                prerequisites_of_calc={self.xc_ticket()},
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self, other.tau_up, other.tau_down, other.initial, converter=converter
            )

        def DoCalcTimeDerivatives(self, context, derivatives):
            derivatives.get_mutable_vector().SetFromVector(
                rotor_lag_rate(
                    self._command.Eval(context),
                    context.get_continuous_state_vector().CopyToVector(),
                    self.tau_up,
                    self.tau_down,
                )
            )

    return Impl


MotorLag = MotorLag_[None]


# --- insertion into the diagram ----------------------------------------------
def add_state_estimate(builder: DiagramBuilder, faults: Faults, state_port):
    """The port the controller reads the state from: `state_port` itself, or
    a StateEstimateError's output when position or velocity noise is on."""
    if faults.position_noise_std == 0.0 and faults.velocity_noise_std == 0.0:
        return state_port
    system = builder.AddNamedSystem("state_estimate", StateEstimateError(faults))
    builder.Connect(state_port, system.get_input_port(0))
    return system.get_output_port(0)


def add_sensor_faults(builder: DiagramBuilder, faults: Faults, obstacle_port):
    """The port the navigator reads the obstacle from: `obstacle_port`
    itself, or a SensorFaults' output when noise, dropouts or latency is on."""
    if (
        faults.sensor_noise_std == 0.0
        and faults.dropout_prob == 0.0
        and delay_samples(faults) == 0
    ):
        return obstacle_port
    system = builder.AddNamedSystem(
        "sensor_faults", SensorFaults(faults, obstacle_port.size())
    )
    builder.Connect(obstacle_port, system.get_input_port(0))
    return system.get_output_port(0)


def add_rotor_faults(
    builder: DiagramBuilder, faults: Faults, hover_command: float, command_port
):
    """The port the plant reads its rotor inputs from: `command_port` itself,
    or through MotorLag (motor_time_constant > 0) and then a Gain that
    scales the weak rotor (weak_rotor_fraction < 1)."""
    port = command_port
    if faults.motor_time_constant > 0.0:
        tau_down = faults.motor_time_constant_down or faults.motor_time_constant
        lag = builder.AddNamedSystem(
            "motor_lag",
            MotorLag(
                faults.motor_time_constant, tau_down, np.full(ROTORS, hover_command)
            ),
        )
        builder.Connect(port, lag.get_input_port(0))
        port = lag.get_output_port(0)
    if faults.weak_rotor_fraction < 1.0:
        k = np.ones(ROTORS)
        k[faults.weak_rotor] = faults.weak_rotor_fraction
        weak = builder.AddNamedSystem("weak_rotor", Gain(k))
        builder.Connect(port, weak.get_input_port(0))
        port = weak.get_output_port(0)
    return port


# --- the faults of a sweep ---------------------------------------------------
def faults_from_yaml(text: str) -> Faults:
    """A `faults:` block given as YAML text (e.g. on the command line);
    raises ValueError naming the field and value."""
    try:
        faults = yaml_load_typed(schema=Faults, data=text.strip() or "{}")
    except Exception as e:  # yaml_load_typed raises several types
        raise ValueError(" ".join(str(e).split())) from None
    for name, value, reason in fault_problems(faults):
        raise ValueError(f"{name} = {value!r}: {reason}")
    return faults


def fault_variant(faults: Faults) -> str:
    """A name for a sweep variant: the fields that differ from the defaults,
    as "field=value" joined by commas ("" for no faults)."""
    default = Faults()
    return ",".join(
        f"{f.name}={getattr(faults, f.name)!r}"
        for f in fields(faults)
        if getattr(faults, f.name) != getattr(default, f.name)
    )


def with_faults(scenario, faults: Faults):
    """A copy of `scenario` with `faults`, the seed offset by a CRC of the
    scenario's name so that the fields of a sweep draw independent noise."""
    seed = faults.seed + zlib.crc32(scenario.name.encode())
    return replace(scenario, faults=replace(faults, seed=seed))
