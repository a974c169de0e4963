"""The vehicle's own chain (§V): the attitude PD (eq 22–25) and the rotor
mixer (eq 8) as LeafSystems over `maths.quadcopter`, templated for
AutoDiffXd like `navigation`. Both copy their parameters at construction.
"""

import copy

import numpy as np
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from mfi_drake.config.vehicle_gains import for_vehicle
from mfi_drake.config.vehicles import Vehicle
from mfi_drake.maths.layout import (
    ROTORS,
    STATE_SIZE,
)
from mfi_drake.maths.quadcopter import (
    attitude_command,
    attitude_gains,
    mix,
    mixer_matrix,
)
from mfi_drake.systems.last_result import LastResult


@TemplateSystem.define("AttitudePD_")
def AttitudePD_(T):
    class Impl(LeafSystem_[T]):
        """Eq 22–25: thrust and roll/pitch/yaw PD torques from F_n.

        .. pydrake_system::

            name: AttitudePD
            input_ports:
            - navigation_force
            - state
            output_ports:
            - thrust_torque
            - attitude_setpoint

        "navigation_force": F_n (3); "state": 12; "thrust_torque":
        [T, τx, τy, τz] (4); "attitude_setpoint": [T, roll_d, pitch_d,
        yaw_d] (4).
        """

        def _construct(self, vehicle, params, K_P=None, K_D=None, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.vehicle = vehicle
            # As given (a copy scales them anew); for the vehicle, to fly.
            self.given_params = copy.deepcopy(params)
            self.params = for_vehicle(self.given_params, vehicle)
            default_P, default_D = attitude_gains(vehicle, self.params)
            self.K_P = default_P if K_P is None else np.array(K_P, float)
            self.K_D = default_D if K_D is None else np.array(K_D, float)
            self._last = LastResult(enabled=T is float)
            self._force = self.DeclareVectorInputPort("navigation_force", 3)
            self._state = self.DeclareVectorInputPort("state", STATE_SIZE)
            tickets = {self._force.ticket(), self._state.ticket()}
            self.DeclareVectorOutputPort(
                "thrust_torque",
                4,
                lambda context, out: out.SetFromVector(self._outputs(context)[0]),
                prerequisites_of_calc=tickets,
            )
            self.DeclareVectorOutputPort(
                "attitude_setpoint",
                4,
                lambda context, out: out.SetFromVector(self._outputs(context)[1]),
                prerequisites_of_calc=tickets,
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(
                self,
                other.vehicle,
                other.given_params,
                other.K_P,
                other.K_D,
                converter=converter,
            )

        def _outputs(self, context):
            """(thrust_torque, attitude_setpoint), computed once for both."""
            x = self._state.Eval(context)
            F_n = self._force.Eval(context)
            return self._last(x.tobytes() + F_n.tobytes(), self._outputs_of, x, F_n)

        def _outputs_of(self, x, F_n):
            return attitude_command(
                x, F_n, self.vehicle, self.params, self.K_P, self.K_D
            )

    return Impl


AttitudePD = AttitudePD_[None]


@TemplateSystem.define("RotorMixer_")
def RotorMixer_(T):
    class Impl(LeafSystem_[T]):
        """Eq 8 inverted for QuadrotorPlant's layout, clipped to [0, u_max].

        .. pydrake_system::

            name: RotorMixer
            input_ports:
            - thrust_torque
            output_ports:
            - propeller_force
            - saturation

        "thrust_torque": 4; "propeller_force": u (4) for the plant;
        "saturation": how many rotors were clipped (1).
        """

        def _construct(self, vehicle: Vehicle, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.vehicle = vehicle
            self._D_inv = np.linalg.inv(mixer_matrix(vehicle)).tolist()
            self._last = LastResult(enabled=T is float)
            self._input = self.DeclareVectorInputPort("thrust_torque", ROTORS)
            tickets = {self._input.ticket()}
            self.DeclareVectorOutputPort(
                "propeller_force",
                ROTORS,
                lambda context, out: out.SetFromVector(self._mix(context)[0]),
                prerequisites_of_calc=tickets,
            )
            self.DeclareVectorOutputPort(
                "saturation",
                1,
                lambda context, out: out.SetAtIndex(0, float(self._mix(context)[1])),
                prerequisites_of_calc=tickets,
            )

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.vehicle, converter=converter)

        def _mix(self, context):
            thrust_torque = self._input.Eval(context)
            return self._last(thrust_torque.tobytes(), self._mix_of, thrust_torque)

        def _mix_of(self, thrust_torque):
            return mix(thrust_torque, self._D_inv, self.vehicle.u_max)

    return Impl


RotorMixer = RotorMixer_[None]
