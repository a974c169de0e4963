"""The motors between the mixer and the rotors: a first-order lag on each
rotor command (`Vehicle.motor_time_constant`), u̇ = (u_cmd − u)/τ, that
starts at the hover command so that a flight starts in balance."""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from mfi_drake.maths.layout import ROTORS


class MotorLag(LeafSystem):
    """Input 0: the 4 rotor commands; output 0: the 4 the rotors deliver,
    the system's state (by default `hover_command` each; no feedthrough)."""

    def __init__(self, time_constant: float, hover_command: float):
        super().__init__()
        self.time_constant = float(time_constant)
        self.DeclareContinuousState(BasicVector(np.full(ROTORS, hover_command)))
        self._command = self.DeclareVectorInputPort("command", ROTORS)
        self.DeclareVectorOutputPort(
            "rotors",
            ROTORS,
            lambda context, out: out.SetFromVector(
                context.get_continuous_state_vector().CopyToVector()
            ),
            prerequisites_of_calc={self.xc_ticket()},
        )

    def DoCalcTimeDerivatives(self, context, derivatives):
        u = context.get_continuous_state_vector().CopyToVector()
        command = self._command.Eval(context)
        derivatives.get_mutable_vector().SetFromVector(
            (command - u) / self.time_constant
        )
