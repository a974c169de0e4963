"""The MultibodyPlant vehicle (`systems.multibody`, `config.vehicle_model`)
against Drake's QuadrotorPlant, hand-computed cases and invariants."""

import numpy as np
import pytest
from pydrake.geometry import Role, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.analysis import (
    ApplySimulatorConfig,
    Simulator,
    SimulatorConfig,
)
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, MatrixGain, Sine

from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.vehicle_model import rotor_positions, vehicle_sdf
from mfi_drake.config.vehicles import VEHICLES, vehicle_model_path
from mfi_drake.flight.diagram import make_plant
from mfi_drake.maths.quadcopter import GRAVITY, plus_commands, wrap_angle
from mfi_drake.systems.control import AttitudePD, RotorMixer
from mfi_drake.systems.multibody import (
    MultibodyVehicleState,
    add_propellers,
    add_vehicle_model,
    add_vehicle_state,
    place_vehicle,
    pose_and_velocity,
    set_vehicle_state,
    vehicle_state,
)

# Tilted, spinning and moving: every term of the rigid-body equations acts.
START = np.array([0.5, -1.0, 2.0, 0.3, -0.2, 0.5, 1.0, -0.5, 0.3, 0.3, -0.2, 1.0])


def multibody_diagram(vehicle: str, command_source=None):
    """A continuous MultibodyPlant with `vehicle`'s model, its Propeller and
    its 12-state; returns (diagram, plant, body, state system, propeller)."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(time_step=0.0))
    body = add_vehicle_model(plant, vehicle)
    plant.Finalize()
    propeller = add_propellers(builder, plant, body, vehicle)
    state = add_vehicle_state(builder, plant, body)
    if command_source is not None:
        builder.Connect(command_source(builder), propeller.get_command_input_port())
    return builder.Build(), plant, body, state, propeller


def quadrotor_diagram(vehicle: str, command_source=None):
    """QuadrotorPlant ("+" rotors); an "x" vehicle's commands reach it
    through `plus_commands`, the map to the "+" commands of the same wrench
    (the MultibodyPlant's Propellers sit where the x rotors are)."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(make_plant(VEHICLES[vehicle]))
    if command_source is not None:
        gain = builder.AddSystem(MatrixGain(plus_commands(VEHICLES[vehicle])))
        builder.Connect(command_source(builder), gain.get_input_port())
        builder.Connect(gain.get_output_port(), plant.get_input_port(0))
    return builder.Build(), plant


def varying_command(vehicle: str):
    """u_k(t) = hover · (1 + a_k sin(ω_k t + φ_k)): a smooth command that
    rolls, pitches and yaws the vehicle by different amounts."""
    hover = VEHICLES[vehicle].hover_command

    def source(builder):
        sine = builder.AddSystem(
            Sine(
                hover * np.array([0.02, 0.012, 0.016, 0.024]),
                np.array([3.0, 5.0, 4.0, 2.0]),
                np.array([0.0, 1.0, 2.0, 3.0]),
            )
        )
        constant = builder.AddSystem(ConstantVectorSource(np.full(4, hover)))
        adder = builder.AddSystem(Adder(2, 4))
        builder.Connect(sine.get_output_port(0), adder.get_input_port(0))
        builder.Connect(constant.get_output_port(), adder.get_input_port(1))
        return adder.get_output_port()

    return source


def simulator(diagram, accuracy: float) -> Simulator:
    sim = Simulator(diagram)
    ApplySimulatorConfig(
        SimulatorConfig(
            integration_scheme="runge_kutta3",
            accuracy=accuracy,
            max_step_size=0.01,
        ),
        sim,
    )
    return sim


def angle_aware_difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = a - b
    d[3:6] = wrap_angle(d[3:6])
    return d


def open_loop_gap(vehicle: str, accuracy: float) -> tuple[float, float]:
    """Both plants flown open loop by `varying_command` from START for 2 s
    at `accuracy`: the largest gap between their 12-states at 20 instants,
    and the largest change of QuadrotorPlant's state from START."""
    qd, quadrotor = quadrotor_diagram(vehicle, varying_command(vehicle))
    md, plant, body, state, _ = multibody_diagram(vehicle, varying_command(vehicle))
    q_sim, m_sim = simulator(qd, accuracy), simulator(md, accuracy)
    q_context = quadrotor.GetMyMutableContextFromRoot(q_sim.get_mutable_context())
    q_context.SetContinuousState(START)
    m_context = plant.GetMyMutableContextFromRoot(m_sim.get_mutable_context())
    set_vehicle_state(plant, m_context, body, START)
    gap, moved = 0.0, 0.0
    for t in np.linspace(0.1, 2.0, 20):
        q_sim.AdvanceTo(t)
        m_sim.AdvanceTo(t)
        x_q = quadrotor.get_output_port(0).Eval(q_context)
        x_m = state.GetOutputPort("state").Eval(
            state.GetMyContextFromRoot(m_sim.get_context())
        )
        gap = max(gap, np.abs(angle_aware_difference(x_m, x_q)).max())
        moved = max(moved, np.abs(angle_aware_difference(x_q, START)).max())
    return gap, moved


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_multibody_vehicle_flies_as_quadrotor_plant(vehicle):
    """Open loop, the same smooth rotor commands from the same tilted,
    spinning, moving start for 2 s (drake_default tumbles: roll passes
    8 rad): the two plants' 12-states agree to 4e-7 at RK3 accuracy 1e-8
    (2e-6 for the 30 g crazyflie, whose rates are the fastest: 7.4e-7).
    Measured: 4.0e-8 (drake_default) and 1.1e-8 (pelican), in the rpy
    rates and the yaw; the bound is 10 times the worse. An "x" vehicle's
    QuadrotorPlant gets its commands through `plus_commands`. They are integrated
    in different coordinates (QuadrotorPlant rpy, the MultibodyPlant a
    quaternion) with different steps, so they agree only to the integration
    error, not bit for bit; that the gap is integration error and not a
    difference of physics shows in its shrinking with the accuracy (at 1e-6
    it is 3.8e-6 and 1.1e-6, about 100 times larger)."""
    gap, moved = open_loop_gap(vehicle, 1e-8)
    coarse, _ = open_loop_gap(vehicle, 1e-6)
    assert moved > 1.0  # the flight is not trivial
    assert gap < (2e-6 if vehicle == "crazyflie" else 4e-7)
    assert coarse > 10 * gap


def closed_loop_states(vehicle: str, multibody: bool) -> np.ndarray:
    """The project's AttitudePD and RotorMixer flying one plant from START
    for 4 s towards a constant navigation force; its 12-state at 20
    instants."""
    v = VEHICLES[vehicle]
    builder = DiagramBuilder()
    force = builder.AddSystem(ConstantVectorSource(v.mass * np.array([1, -0.5, 0.3])))
    attitude = builder.AddSystem(AttitudePD(v, NavigatorParams()))
    mixer = builder.AddSystem(RotorMixer(v))
    builder.Connect(force.get_output_port(), attitude.GetInputPort("navigation_force"))
    builder.Connect(
        attitude.GetOutputPort("thrust_torque"), mixer.GetInputPort("thrust_torque")
    )
    if multibody:
        plant = builder.AddSystem(MultibodyPlant(time_step=0.0))
        body = add_vehicle_model(plant, vehicle)
        plant.Finalize()
        command = add_propellers(builder, plant, body, vehicle).get_command_input_port()
        state = add_vehicle_state(builder, plant, body).GetOutputPort("state")
    else:
        plant = builder.AddSystem(make_plant(v))
        gain = builder.AddSystem(MatrixGain(plus_commands(v)))  # "x": its wrench
        builder.Connect(gain.get_output_port(), plant.get_input_port(0))
        command, state = gain.get_input_port(), plant.get_output_port(0)
    builder.Connect(state, attitude.GetInputPort("state"))
    builder.Connect(mixer.GetOutputPort("propeller_force"), command)
    sim = simulator(builder.Build(), 1e-8)
    plant_context = plant.GetMyMutableContextFromRoot(sim.get_mutable_context())
    if multibody:
        set_vehicle_state(plant, plant_context, body, START)
    else:
        plant_context.SetContinuousState(START)
    states = []
    for t in np.linspace(0.2, 4.0, 20):
        sim.AdvanceTo(t)
        states.append(
            state.Eval(state.get_system().GetMyContextFromRoot(sim.get_context()))
        )
    return np.array(states)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_project_controller_flies_both_plants_alike(vehicle):
    """Closed loop through the project's attitude PD and mixer, from the
    tilted, spinning start, 4 s: the states agree to 1e-7 (measured 3.1e-9
    for drake_default, 1.0e-8 for pelican, at RK3 accuracy 1e-8), so the
    controller reads MultibodyVehicleState as it reads QuadrotorPlant's
    state and its rotor commands act alike."""
    quadrotor = closed_loop_states(vehicle, multibody=False)
    multibody = closed_loop_states(vehicle, multibody=True)
    assert np.linalg.norm(quadrotor[-1, :3] - START[:3]) > 5.0  # it flew
    gap = [
        angle_aware_difference(m, q) for m, q in zip(multibody, quadrotor, strict=True)
    ]
    assert np.abs(gap).max() < 1e-7


def test_state_of_a_hand_computed_rotation():
    """Pitch π/4 (roll = yaw = 0), angular velocity ω_W = (1, 0.5, 0):
    with R = Ry(θ), ω_W = (φ̇ cos θ, θ̇, ψ̇ − φ̇ sin θ), so the rpy rates
    are (1/cos θ, 0.5, tan θ) = (√2, 0.5, 1)."""
    system = MultibodyVehicleState(body_index=1)
    context = system.CreateDefaultContext()
    p, v = np.array([1.0, 2.0, 3.0]), np.array([-1.0, 0.5, 0.25])
    X_WB = RigidTransform(RollPitchYaw(0.0, np.pi / 4, 0.0), p)
    V_WB = SpatialVelocity(np.array([1.0, 0.5, 0.0]), v)
    system.GetInputPort("body_poses").FixValue(context, [RigidTransform(), X_WB])
    system.GetInputPort("body_spatial_velocities").FixValue(
        context, [SpatialVelocity.Zero(), V_WB]
    )
    expected = np.concatenate([p, [0.0, np.pi / 4, 0.0], v, [np.sqrt(2.0), 0.5, 1.0]])
    state = system.GetOutputPort("state").Eval(context)
    np.testing.assert_allclose(state, expected, rtol=0, atol=1e-14)
    X, V = pose_and_velocity(state)  # and back
    assert X.IsNearlyEqualTo(X_WB, 1e-14)
    np.testing.assert_allclose(V.get_coeffs(), V_WB.get_coeffs(), atol=1e-14)


def test_state_round_trip():
    X, V = pose_and_velocity(START)
    np.testing.assert_allclose(vehicle_state(X, V), START, rtol=0, atol=1e-14)


def multibody_accelerations(vehicle: str, command, position, rpy) -> SpatialVelocity:
    """The body's spatial acceleration at rest at `position`, `rpy` under the
    rotor command `command`: (angular, translational) in the world."""
    diagram, plant, body, _, propeller = multibody_diagram(vehicle)
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    place_vehicle(plant, plant_context, body, position, rpy)
    propeller.get_command_input_port().FixValue(
        propeller.GetMyMutableContextFromRoot(context), command
    )
    vdot = diagram.EvalTimeDerivatives(context).get_vector().CopyToVector()[-6:]
    return vdot[:3], vdot[3:]


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_hover_command_holds_the_vehicle_still(vehicle):
    """u_k = m g / (4 kF) on each rotor: zero acceleration, wherever the
    level vehicle is and whatever its heading."""
    hover = np.full(4, VEHICLES[vehicle].hover_command)
    for position, yaw in [((0, 0, 0), 0.0), ((3.0, -2.0, 1.5), 2.0)]:
        angular, linear = multibody_accelerations(vehicle, hover, position, (0, 0, yaw))
        np.testing.assert_allclose(angular, 0.0, atol=1e-12)
        np.testing.assert_allclose(linear, 0.0, atol=1e-12 * GRAVITY)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_differential_command_yaws_as_quadrotor_plant(vehicle):
    """u = hover + d (1, −1, 1, −1): no net force change, a yaw torque
    4 kM d, so ψ̈ = 4 kM d / Izz (positive: rotors 0 and 2 twist +z), the
    same in both plants; nothing else accelerates."""
    v = VEHICLES[vehicle]
    d = 0.1 * v.hover_command
    command = v.hover_command + d * np.array([1.0, -1.0, 1.0, -1.0])
    yaw_acceleration = 4 * v.kM * d / v.inertia[2]
    assert yaw_acceleration > 0
    angular, linear = multibody_accelerations(vehicle, command, (0, 0, 1), (0, 0, 0.7))
    np.testing.assert_allclose(
        angular, [0, 0, yaw_acceleration], rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(linear, 0.0, atol=1e-12)
    diagram, quadrotor = quadrotor_diagram(vehicle)
    context = quadrotor.CreateDefaultContext()
    context.SetContinuousState(np.r_[0, 0, 1, 0, 0, 0.7, np.zeros(6)])
    quadrotor.get_input_port(0).FixValue(context, command)
    rpy_ddt = quadrotor.EvalTimeDerivatives(context).CopyToVector()[9:]
    np.testing.assert_allclose(rpy_ddt, angular, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
def test_shipped_model_is_the_vehicle_record(vehicle):
    """The file is what `vehicle_sdf` writes from the record (else run
    `python -m mfi_drake.config.vehicle_model`), and Drake's parser reads
    from it the record's mass, principal inertia at the body origin, one
    collision sphere of the collision radius, no geometry a camera sees and
    rotor discs at the arm length on ±x, ±y."""
    v = VEHICLES[vehicle]
    with open(vehicle_model_path(vehicle)) as f:
        assert f.read() == vehicle_sdf(v)
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    body = add_vehicle_model(plant, vehicle)
    plant.Finalize()
    assert body.name() == "body" and body.is_floating_base_body()
    inertia = body.default_spatial_inertia()
    assert inertia.get_mass() == v.mass
    np.testing.assert_array_equal(inertia.get_com(), 0.0)
    np.testing.assert_allclose(
        inertia.CalcRotationalInertia().CopyToFullMatrix3(),
        v.inertia_matrix(),
        rtol=1e-15,
        atol=0,
    )
    inspector = scene_graph.model_inspector()
    frame = plant.GetBodyFrameIdOrThrow(body.index())
    (collision,) = inspector.GetGeometries(frame, Role.kProximity)
    shape = inspector.GetShape(collision)
    assert isinstance(shape, Sphere) and shape.radius() == v.collision_radius
    assert not inspector.GetGeometries(frame, Role.kPerception)  # cameras see none
    rotors = {
        inspector.GetName(g).split("::")[-1]: inspector.GetPoseInFrame(g).translation()
        for g in inspector.GetGeometries(frame, Role.kIllustration)
    }
    d = v.arm_length / np.sqrt(2.0)  # an "x" vehicle's rotors, on the diagonals
    expected = {
        "+": [
            (v.arm_length, 0),
            (0, v.arm_length),
            (-v.arm_length, 0),
            (0, -v.arm_length),
        ],
        "x": [(d, d), (-d, d), (-d, -d), (d, -d)],
    }[v.layout]
    for k, xy in enumerate(expected):
        np.testing.assert_allclose(rotors[f"rotor_{k}"][:2], xy, atol=1e-15)
        np.testing.assert_allclose(
            rotor_positions(v.arm_length, v.layout)[k][:2], xy, atol=1e-15
        )


def test_two_vehicles_coexist_and_unknown_names_fail():
    plant = MultibodyPlant(0.0)
    a = add_vehicle_model(plant, "drake_default", model_name="first")
    b = add_vehicle_model(plant, "drake_default", model_name="second")
    assert plant.GetModelInstanceName(a.model_instance()) == "first"
    assert plant.GetModelInstanceName(b.model_instance()) == "second"
    with pytest.raises(ValueError, match="vehicle = 'zeppelin'"):
        vehicle_model_path("zeppelin")
    with pytest.raises(ValueError, match="vehicle = 'zeppelin'"):
        add_vehicle_model(plant, "zeppelin")


def test_add_propellers_refuses_a_second_vehicle_and_an_unknown_name():
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(time_step=0.0))
    first = add_vehicle_model(plant, "drake_default", model_name="first")
    second = add_vehicle_model(plant, "pelican", model_name="second")
    plant.Finalize()
    with pytest.raises(ValueError, match="vehicle = 'zeppelin'"):
        add_propellers(builder, plant, first, "zeppelin")
    propeller = add_propellers(builder, plant, first, VEHICLES["drake_default"])
    assert propeller.num_propellers() == 4
    with pytest.raises(ValueError, match="plant: its applied_spatial_force input"):
        add_propellers(builder, plant, second, "pelican")
