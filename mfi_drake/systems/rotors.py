"""The motors between the mixer and the rotors: a first-order lag on each
rotor command (`Vehicle.motor_time_constant`), u̇ = (u_cmd − u)/τ, that
starts at the hover command so that a flight starts in balance."""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from mfi_drake.maths.layout import ROTORS


class MotorLag(LeafSystem):
    """Input 0: the 4 rotor commands; output 0: the 4 the rotors deliver
    (no feedthrough). Its state is u / `hover_command` (1 at hover, the
    default): the integrator's error control weighs states of order 1,
    where u in (rad/s)² is of order 1e5."""

    def __init__(self, time_constant: float, hover_command: float):
        super().__init__()
        self.time_constant = float(time_constant)
        self.hover_command = float(hover_command)
        self.DeclareContinuousState(BasicVector(np.ones(ROTORS)))
        self._command = self.DeclareVectorInputPort("command", ROTORS)
        self.DeclareVectorOutputPort(
            "rotors",
            ROTORS,
            lambda context, out: out.SetFromVector(
                self.hover_command
                * context.get_continuous_state_vector().CopyToVector()
            ),
            prerequisites_of_calc={self.xc_ticket()},
        )

    def DoCalcTimeDerivatives(self, context, derivatives):
        s = context.get_continuous_state_vector().CopyToVector()
        target = self._command.Eval(context) / self.hover_command
        derivatives.get_mutable_vector().SetFromVector(
            (target - s) / self.time_constant
        )
