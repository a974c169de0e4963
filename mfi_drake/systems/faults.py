"""The fault systems, and the helpers that insert them into a flight's
diagram only when the scenario turns them on.

A scenario's optional `faults:` block (`config.faults.Faults`) turns
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

import copy

import numpy as np
from pydrake.systems.framework import BasicVector_, DiagramBuilder, LeafSystem_
from pydrake.systems.primitives import Gain
from pydrake.systems.scalar_conversion import TemplateSystem

from mfi_drake.config.faults import Faults, delay_samples
from mfi_drake.maths.faults import (
    ESTIMATE_STREAM,
    SENSOR_STREAM,
    corrupt_reading,
    estimate_error,
    rotor_lag_rate,
    sample_index,
    sample_rng,
)
from mfi_drake.maths.layout import ROTORS, STATE_SIZE


@TemplateSystem.define("SensorFaults_")
def SensorFaults_(T):
    class Impl(LeafSystem_[T]):
        """Noise, dropouts and latency of the obstacle reading.

        Every 1/sample_rate s the reading is sampled, corrupted by
        `corrupt_reading` and pushed into a delay line of delay_samples + 1
        samples held in discrete state; the output is the oldest sample
        ("nothing seen" until the first sample has come through).

        .. pydrake_system::

            name: SensorFaults
            input_ports:
            - obstacle
            output_ports:
            - obstacle

        Input "obstacle": the true reading (`size` values, `maths.layout`);
        output "obstacle": the corrupted one.
        """

        def _construct(self, faults: Faults, size: int, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.faults = copy.deepcopy(faults)
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

        .. pydrake_system::

            name: StateEstimateError
            input_ports:
            - state
            output_ports:
            - estimate

        "state": the true 12-vector; "estimate": what the controller sees.
        """

        def _construct(self, faults: Faults, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.faults = copy.deepcopy(faults)
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

        .. pydrake_system::

            name: MotorLag
            input_ports:
            - command
            output_ports:
            - propeller_force

        "command": u_cmd (4); "propeller_force": u (4), the state.
        """

        def _construct(self, tau_up, tau_down, initial, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.tau_up, self.tau_down = float(tau_up), float(tau_down)
            self.initial = np.asarray(initial, dtype=float)
            self._command = self.DeclareVectorInputPort("command", ROTORS)
            state = self.DeclareContinuousState(BasicVector_[T](self.initial))
            self.DeclareStateOutputPort("propeller_force", state)

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
def estimate_faulted(faults: Faults) -> bool:
    """Whether `faults` make the state estimate differ from the state."""
    return faults.position_noise_std != 0.0 or faults.velocity_noise_std != 0.0


def readings_faulted(faults: Faults) -> bool:
    """Whether `faults` make the navigator's readings differ from the
    sensor's (noise, dropouts or latency)."""
    return (
        faults.sensor_noise_std != 0.0
        or faults.dropout_prob != 0.0
        or delay_samples(faults) != 0
    )


def add_state_estimate(builder: DiagramBuilder, faults: Faults, state_port):
    """The port the controller reads the state from: `state_port` itself, or
    a StateEstimateError's output when position or velocity noise is on."""
    if not estimate_faulted(faults):
        return state_port
    system = builder.AddNamedSystem("state_estimate", StateEstimateError(faults))
    builder.Connect(state_port, system.get_input_port(0))
    return system.get_output_port(0)


def add_sensor_faults(builder: DiagramBuilder, faults: Faults, obstacle_port):
    """The port the navigator reads the obstacle from: `obstacle_port`
    itself, or a SensorFaults' output when noise, dropouts or latency is on."""
    if not readings_faulted(faults):
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
