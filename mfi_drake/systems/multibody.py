"""A shipped vehicle as a free body of a `MultibodyPlant`, flown by Drake's
`Propeller` with the physics of Drake's `QuadrotorPlant`.

    MultibodyPlant ──body_poses──────────────▶ Propeller ──spatial_forces──┐
        │  ▲                                      ▲ command (4 rotor u)    │
        │  └──applied_spatial_force───────────────┼────────────────────────┘
        ├──body_poses, body_spatial_velocities──▶ MultibodyVehicleState ──state──▶

Rotor k (k = 0..3, on the body's +x, +y, −x, −y axes) pushes kF·u_k along
the body's +z and twists ±kM·u_k about it (+ for rotors 0 and 2), as
QuadrotorPlant's input "propeller_force" does; gravity is the plant's own
(9.81 m/s² by default, QuadrotorPlant's g). The body frame is the centre
of mass, so the plant's body pose is QuadrotorPlant's (x, y, z, rpy).

Keep the plant continuous (time_step = 0) to fly it as QuadrotorPlant is
flown, by the simulator's error-controlled integrator (tests: 4e-8 apart
after 2 s at RK3 accuracy 1e-8). Unlike QuadrotorPlant, the body has a
collision sphere: a plant that also holds the world's geometry applies
contact forces when the vehicle touches it, and a sensor must not take the
sphere (on `plant.GetBodyFrameIdOrThrow(body.index())`) for an obstacle.

`MultibodyVehicleState` writes the 12-state of QuadrotorPlant's output
"state": position, roll-pitch-yaw, velocity and the rpy *rates* (not the
body's angular velocity). Its yaw is read from the rotation, so it lies in
[−π, π], where QuadrotorPlant's integrated yaw runs on past ±π.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant, Propeller, PropellerInfo
from pydrake.multibody.tree import BodyIndex, RigidBody
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem

from mfi_drake.config.vehicle_model import ROTOR_SPIN, rotor_positions, vehicle_sdf
from mfi_drake.config.vehicles import Vehicle, as_vehicle, vehicle_model_path
from mfi_drake.maths.layout import STATE_SIZE


def add_vehicle_model(
    plant: MultibodyPlant,
    vehicle: str | Vehicle = "drake_default",
    model_name: str | None = None,
) -> RigidBody:
    """Parses the shipped model of `vehicle` (a preset's name), or the model
    `config.vehicle_model.vehicle_sdf` writes of a `Vehicle`, into the
    unfinalized `plant` and returns its free body "body". `model_name`
    names the model instance (default: the vehicle's name), so that several
    vehicles can coexist."""
    if isinstance(vehicle, str):
        (instance,) = Parser(plant).AddModels(vehicle_model_path(vehicle))
    else:
        text = vehicle_sdf(as_vehicle(vehicle))
        (instance,) = Parser(plant).AddModelsFromString(text, "sdf")
    if model_name is not None:
        plant.RenameModelInstance(instance, model_name)
    return plant.GetBodyByName("body", instance)


def vehicle_state(X_WB: RigidTransform, V_WB: SpatialVelocity) -> np.ndarray:
    """QuadrotorPlant's 12-state of a body at pose `X_WB` moving with
    spatial velocity `V_WB` (in the world, about the body origin)."""
    rpy = RollPitchYaw(X_WB.rotation())
    rpy_dt = rpy.CalcRpyDtFromAngularVelocityInParent(V_WB.rotational())
    return np.concatenate(
        [X_WB.translation(), rpy.vector(), V_WB.translational(), rpy_dt]
    )


def pose_and_velocity(state) -> tuple[RigidTransform, SpatialVelocity]:
    """The inverse of `vehicle_state`: X_WB and V_WB of a 12-state."""
    state = np.asarray(state, dtype=float)
    rpy = RollPitchYaw(state[3:6])
    w_WB_W = rpy.CalcAngularVelocityInParentFromRpyDt(state[9:12])
    return RigidTransform(rpy, state[:3]), SpatialVelocity(w_WB_W, state[6:9])


class MultibodyVehicleState(LeafSystem):
    """QuadrotorPlant's 12-state (`vehicle_state`) of one body of a
    MultibodyPlant, so that systems written for QuadrotorPlant's output
    "state" fly the body. `body_index`: the body's (`body.index()`).

    .. pydrake_system::

        name: MultibodyVehicleState
        input_ports:
        - body_poses
        - body_spatial_velocities
        output_ports:
        - state

    Connect the inputs from the plant's `get_body_poses_output_port()` and
    `get_body_spatial_velocities_output_port()` (`add_vehicle_state` does).
    """

    def __init__(self, body_index: BodyIndex):
        super().__init__()
        self._index = int(body_index)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", AbstractValue.Make([RigidTransform()])
        )
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", AbstractValue.Make([SpatialVelocity()])
        )
        self.DeclareVectorOutputPort(
            "state",
            STATE_SIZE,
            self._calc,
            prerequisites_of_calc={self._poses.ticket(), self._velocities.ticket()},
        )

    def _calc(self, context: Context, output) -> None:
        X_WB = self._poses.Eval(context)[self._index]
        V_WB = self._velocities.Eval(context)[self._index]
        output.SetFromVector(vehicle_state(X_WB, V_WB))


def add_vehicle_state(
    builder: DiagramBuilder, plant: MultibodyPlant, body: RigidBody
) -> MultibodyVehicleState:
    """Adds `body`'s `MultibodyVehicleState`, named "state_" + its model
    instance's name, fed by the finalized `plant` in `builder`."""
    state = builder.AddNamedSystem(
        f"state_{plant.GetModelInstanceName(body.model_instance())}",
        MultibodyVehicleState(body.index()),
    )
    builder.Connect(
        plant.get_body_poses_output_port(), state.GetInputPort("body_poses")
    )
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(),
        state.GetInputPort("body_spatial_velocities"),
    )
    return state


def add_propellers(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    body: RigidBody,
    vehicle: str | Vehicle,
) -> Propeller:
    """Adds Drake's `Propeller` with `vehicle`'s four rotors on `body` (see
    the module's docstring) and connects it to `plant` both ways; its
    `get_command_input_port()` takes QuadrotorPlant's input, the four rotor
    commands u. The plant's applied-spatial-force input takes one source,
    so this serves one vehicle per plant."""
    vehicle = as_vehicle(vehicle)  # a clear error for an unknown name
    forces = plant.get_applied_spatial_force_input_port()
    if builder.IsConnectedOrExported(forces):
        raise ValueError(
            "plant: its applied_spatial_force input is already connected;"
            " add_propellers drives one vehicle per plant"
        )
    rotors = [
        PropellerInfo(
            body.index(),
            RigidTransform(position),
            vehicle.kF,
            spin * vehicle.kM,
        )
        for position, spin in zip(
            rotor_positions(vehicle.arm_length, vehicle.layout), ROTOR_SPIN, strict=True
        )
    ]
    propeller = builder.AddNamedSystem(
        f"propeller_{plant.GetModelInstanceName(body.model_instance())}",
        Propeller(rotors),
    )
    builder.Connect(
        plant.get_body_poses_output_port(), propeller.get_body_poses_input_port()
    )
    builder.Connect(propeller.get_spatial_forces_output_port(), forces)
    return propeller


def set_vehicle_state(
    plant: MultibodyPlant, plant_context: Context, body: RigidBody, state
) -> None:
    """Puts `body` in QuadrotorPlant's 12-state `state` (`pose_and_velocity`)."""
    X_WB, V_WB = pose_and_velocity(state)
    plant.SetFreeBodyPose(plant_context, body, X_WB)
    plant.SetFreeBodySpatialVelocity(plant_context, body, V_WB)


def place_vehicle(
    plant: MultibodyPlant,
    plant_context: Context,
    body: RigidBody,
    position,
    rpy=(0.0, 0.0, 0.0),
) -> None:
    """Puts `body` at rest at `position` with attitude `rpy` (roll, pitch,
    yaw) [m, rad]."""
    set_vehicle_state(
        plant, plant_context, body, np.concatenate([position, rpy, np.zeros(6)])
    )
