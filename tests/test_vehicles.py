"""Any quadrotor (docs/vehicles.md): `vehicle:` as a preset, an inline
`!Vehicle` or a `!VehicleModel` file; bad values refused in one line with
exit status 2; the gains of `config.vehicle_gains` (the presets' exactly
as given, every other vehicle's dynamically similar to them); the motors'
lag; and every entry point taking the same vehicle."""

import dataclasses
import math
import os

import numpy as np
import pytest
from pydrake.geometry import SceneGraph
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from mfi_drake import (
    NavigationStep,
    add_navigation,
    add_vehicle_model,
    load_scenario,
    simulate,
)
from mfi_drake.app.cli import main
from mfi_drake.config.parameters import NavigatorParams
from mfi_drake.config.scenario_yaml import (
    parse_scenario,
    scenario_from_yaml,
    scenario_to_yaml,
)
from mfi_drake.config.vehicle_gains import UNITS, for_vehicle, scales
from mfi_drake.config.vehicle_model import VehicleModel, read_vehicle_model
from mfi_drake.config.vehicles import (
    VEHICLES,
    Vehicle,
    VehicleError,
    as_vehicle,
    vehicle_model_path,
)
from mfi_drake.systems.rotors import motor_lag

from .conftest import SCENARIOS

PLANAR_WALL = os.path.join(SCENARIOS, "planar_wall.yaml")
INLINE = (
    "!Vehicle {name: mine, mass: 1.2, arm_length: 0.2, inertia: [0.01, 0.012, "
    "0.02], kF: 1.0, kM: 0.02, u_max: 6.0, rotor_radius: 0.1, layout: x, "
    "motor_time_constant: 0.02}"
)


def custom(**changes) -> Vehicle:
    return dataclasses.replace(VEHICLES["drake_default"], name="custom", **changes)


# --- the three forms ----------------------------------------------------------
def test_an_inline_vehicle_loads_and_travels_as_yaml(write_yaml):
    path = write_yaml(f"name: a\ngoal: [5, 0, 1.5]\nvehicle: {INLINE}\n")
    scenario = parse_scenario(path)
    v = scenario.vehicle
    assert isinstance(v, Vehicle) and v.inertia == (0.01, 0.012, 0.02)
    assert (v.layout, v.motor_time_constant, v.u_max) == ("x", 0.02, 6.0)
    assert scenario_from_yaml(scenario_to_yaml(scenario)).vehicle == v


def test_a_model_file_gives_back_the_record_it_was_written_from(write_yaml, tmp_path):
    """The shipped models have no rotor bodies: the arm is the collision
    sphere's radius less the rotor radius, which the record wrote."""
    for name, preset in VEHICLES.items():
        model = VehicleModel(
            file=f"{name}.sdf",
            kF=preset.kF,
            kM=preset.kM,
            u_max=preset.u_max,
            rotor_radius=preset.rotor_radius,
            layout=preset.layout,
        )
        got = read_vehicle_model(model, VEHICLES_DIR)
        assert got.mass == pytest.approx(preset.mass, rel=1e-12)
        assert got.arm_length == pytest.approx(preset.arm_length, rel=1e-12)
        assert got.inertia == pytest.approx(preset.inertia, rel=1e-12)
    text = "name: b\ngoal: [5, 0, 1.5]\nvehicle: !VehicleModel {file: m.sdf, "
    text += "kF: 1.0, kM: 0.0245, u_max: 4.0, rotor_radius: 0.075}\n"
    path = write_yaml(text)
    (tmp_path / "m.sdf").write_text(shipped_model())
    assert parse_scenario(path).vehicle.arm_length == pytest.approx(0.15)


VEHICLES_DIR = os.path.dirname(vehicle_model_path("drake_default"))


def shipped_model() -> str:
    with open(vehicle_model_path("drake_default")) as f:
        return f.read()


ROTOR_URDF = """<?xml version="1.0"?>
<robot name="quad">
  <link name="base"><inertial><mass value="1.6"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.035" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
{rotors}
</robot>
"""
ROTOR = """  <link name="rotor_{k}"><inertial><mass value="0.1"/>
    <inertia ixx="1e-5" iyy="1e-5" izz="2e-5" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="j{k}" type="fixed"><parent link="base"/><child link="rotor_{k}"/>
    <origin xyz="{x} {y} 0.02"/></joint>"""


def test_a_urdf_with_rotor_links_gives_mass_inertia_arm_and_layout(tmp_path):
    """Hand oracle: four 0.1 kg rotors at 0.25 m on the diagonals about a
    1.6 kg base; their centre of mass 0.02 m up is 0.004 m above the
    base's (parallel axis theorem for the moments)."""
    d = 0.25 / math.sqrt(2.0)
    places = [(d, d), (-d, d), (-d, -d), (d, -d)]
    rotors = "\n".join(ROTOR.format(k=k, x=x, y=y) for k, (x, y) in enumerate(places))
    (tmp_path / "quad.urdf").write_text(ROTOR_URDF.format(rotors=rotors))
    model = VehicleModel(file="quad.urdf", kF=1.0, kM=0.02, u_max=8.0, rotor_radius=0.1)
    v = read_vehicle_model(model, str(tmp_path))
    assert v.mass == pytest.approx(2.0) and v.layout == "x"
    assert v.arm_length == pytest.approx(0.25)
    z = 0.4 * 0.02 / 2.0  # the centre of mass's height above the base
    Ixx = 0.02 + 1.6 * z**2 + 4 * (1e-5 + 0.1 * (d**2 + (0.02 - z) ** 2))
    Izz = 0.035 + 4 * (2e-5 + 0.1 * 0.25**2)
    assert v.inertia == pytest.approx((Ixx, Ixx, Izz), rel=1e-9)


# --- bad values: one line, exit status 2 ---------------------------------------
@pytest.mark.parametrize(
    ("changes", "field", "words"),
    [
        ({"mass": 0.0}, "vehicle.mass", "must be a number > 0"),
        ({"mass": -1.0}, "vehicle.mass", "must be a number > 0"),
        ({"u_max": 2.0}, "vehicle.u_max", "thrust to weight"),  # 4·2/(0.775 g) = 1.05
        ({"inertia": [0.001, 0.001, 0.003]}, "vehicle.inertia", "triangle"),
        ({"arm_length": 0.0}, "vehicle.arm_length", "> 0"),
        ({"rotor_radius": -0.1}, "vehicle.rotor_radius", "> 0"),
        ({"kF": 0.0}, "vehicle.kF", "> 0"),
        ({"layout": "h"}, "vehicle.layout", "must be one of"),
    ],
)
def test_a_bad_vehicle_is_one_line_and_exit_status_2(
    tmp_path, capsys, changes, field, words
):
    v = {**dataclasses.asdict(VEHICLES["drake_default"]), **changes}
    v["inertia"] = list(v["inertia"])
    inline = "!Vehicle {" + ", ".join(f"{k}: {val!r}" for k, val in v.items()) + "}"
    inline = inline.replace("'", "")
    args = ["run", PLANAR_WALL, "--set", f"vehicle: {inline}", "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{field} = " in err and words in err, err
    with pytest.raises(VehicleError):
        as_vehicle(Vehicle(**{**v, "inertia": tuple(v["inertia"])}))


def test_an_unknown_preset_names_the_presets(tmp_path, capsys):
    args = ["run", PLANAR_WALL, "--set", "vehicle: bumblebee", "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "vehicle = 'bumblebee'" in err and "crazyflie" in err


# --- the gains ------------------------------------------------------------------
@pytest.mark.parametrize("name", ["drake_default", "pelican"])
def test_the_presets_fly_the_gains_as_given(name):
    params = NavigatorParams()
    assert for_vehicle(params, VEHICLES[name]) is params
    assert scales(VEHICLES[name], params) == (1.0, 1.0, 1.0)


def test_a_vehicle_inside_the_band_keeps_the_gains():
    inside = custom(mass=0.9, arm_length=0.2)  # 0.9 kg, radius 0.275 m
    params = NavigatorParams()
    assert for_vehicle(params, inside) is params


@pytest.mark.parametrize("name", ["crazyflie", "hummingbird", "x500"])
def test_gains_keep_the_dimensionless_groups_of_the_reference(name):
    """Dimensional analysis as the oracle: with lengths in λ, masses in μ
    and times in t, every group of the eq 12–21 gains is the reference's:
    the PD's K_P t²/m, the cruise v_d t/λ, the field's accelerations
    c v_d/(r_l m) and c⊥/(r_b³ m) in λ/t², the tilt held."""
    vehicle, ref = VEHICLES[name], NavigatorParams()
    got = for_vehicle(ref, vehicle)
    mu, lam, t = scales(vehicle, ref)
    m0 = vehicle.mass / mu  # the reference mass
    assert got.K_P * t**2 / vehicle.mass == pytest.approx(ref.K_P / m0)
    assert got.v_d * t / lam == pytest.approx(ref.v_d)
    assert got.r_l / lam == pytest.approx(ref.r_l)
    accel = got.c * got.v_d / (got.r_l * vehicle.mass) * t**2 / lam
    assert accel == pytest.approx(ref.c * ref.v_d / (ref.r_l * m0))
    accel = got.c_perp / (got.r_b**3 * vehicle.mass) * t**2 / lam
    assert accel == pytest.approx(ref.c_perp / (ref.r_b**3 * m0))
    assert got.attitude_natural_frequency * t == pytest.approx(15.0)
    assert set(UNITS) >= {"c", "r_l", "v_d", "K_P", "max_pd_force"}


@pytest.mark.parametrize("name", sorted(VEHICLES))
def test_the_attitude_loop_with_the_motor_lag_is_stable(name):
    """Each axis, J s² (τ s + 1) + K_D s + K_P = 0 with the vehicle's gains:
    roots in the left half-plane (and the authority check: a max_tilt step
    asks for at most the vehicle's angular acceleration)."""
    from mfi_drake.config.vehicle_gains import angular_authority
    from mfi_drake.maths.quadcopter import attitude_gains

    vehicle = VEHICLES[name]
    params = for_vehicle(NavigatorParams(), vehicle)
    K_P, K_D = attitude_gains(vehicle, params)
    tau = vehicle.motor_time_constant
    for J, P, D in zip(vehicle.inertia, K_P, K_D, strict=True):
        roots = np.roots([J * tau, J, D, P])
        assert roots.real.max() < 0.0
    w = params.attitude_natural_frequency
    assert w**2 * params.max_tilt <= angular_authority(vehicle) * (1 + 1e-12)


def test_a_low_thrust_vehicle_gets_a_lower_tilt_limit():
    """cos θ = 1/(0.9 T/W): at T/W 1.25, θ = acos(0.889) = 0.476 rad."""
    low = custom(u_max=1.25 * VEHICLES["drake_default"].weight / 4.0)
    got = for_vehicle(NavigatorParams(), low).max_tilt
    assert got == pytest.approx(math.acos(1.0 / (0.9 * 1.25)))


# --- the motors' lag --------------------------------------------------------------
def test_the_motor_lag_is_first_order_from_hover():
    """Closed form: u(t) = c + (h − c) e^(−t/τ) for a step to c from hover h."""
    tau, h, c = 0.03, 2.0, 3.0
    builder = DiagramBuilder()
    lag = builder.AddSystem(motor_lag(tau, h))
    source = builder.AddSystem(ConstantVectorSource(np.full(4, c)))
    builder.Connect(source.get_output_port(), lag.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = lag.GetMyContextFromRoot(simulator.get_context())
    np.testing.assert_allclose(lag.get_output_port().Eval(context), h)
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    simulator.AdvanceTo(0.05)
    want = c + (h - c) * math.exp(-0.05 / tau)
    np.testing.assert_allclose(lag.get_output_port().Eval(context), want, rtol=1e-6)


# --- every entry point takes the same vehicle ------------------------------------
def test_the_step_takes_a_vehicle_record_as_its_preset_name():
    record = dataclasses.replace(VEHICLES["pelican"], name="renamed")
    x = np.zeros(12)
    x[:3] = [0.0, 0.0, 1.5]
    x[6] = 0.8
    points = np.array([[2.0, 0.3, 1.5]])
    by_name = NavigationStep([8.0, 0.0, 1.5], vehicle="pelican").step(x, points)
    by_record = NavigationStep([8.0, 0.0, 1.5], vehicle=record).step(x, points)
    np.testing.assert_array_equal(by_name.propeller_force, by_record.propeller_force)
    small = NavigationStep([8.0, 0.0, 1.5], vehicle="crazyflie").step(x, points)
    # Forces per unit mass: the crazyflie's F_n is a few per cent of pelican's.
    assert np.linalg.norm(small.navigation_force) < 0.1 * np.linalg.norm(
        by_name.navigation_force
    )


def test_add_navigation_flies_a_body_with_its_own_mass_and_inertia():
    """A MultibodyPlant body heavier than the preset: the controller is
    built for the body's mass and inertia (the preset's rotors)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    text = shipped_model().replace("<mass>0.775</mass>", "<mass>1.1</mass>")
    (instance,) = Parser(plant).AddModelsFromString(text, "sdf")
    plant.Finalize()
    body = plant.GetBodyByName("body", instance)
    handles = add_navigation(builder, plant, scene_graph, [3.0, 0.0, 1.5], body=body)
    assert handles.vehicle.mass == 1.1
    assert handles.vehicle.inertia == pytest.approx((0.0015, 0.0025, 0.0035))
    assert handles.selector.mass == 1.1
    assert isinstance(scene_graph, SceneGraph)


def test_add_navigation_refuses_a_body_too_heavy_for_its_rotors():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    text = shipped_model().replace("<mass>0.775</mass>", "<mass>1.5</mass>")  # T/W 1.09
    (instance,) = Parser(plant).AddModelsFromString(text, "sdf")
    plant.Finalize()
    body = plant.GetBodyByName("body", instance)
    from mfi_drake import BuilderError

    with pytest.raises(BuilderError, match="thrust to weight"):
        add_navigation(builder, plant, scene_graph, [3.0, 0.0, 1.5], body=body)


def test_add_vehicle_model_writes_a_records_model():
    record = custom(mass=0.9, layout="x")
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    body = add_vehicle_model(plant, record)
    plant.Finalize()
    assert body.default_mass() == 0.9
    handles = add_navigation(
        builder, plant, scene_graph, [3.0, 0.0, 1.5], body=body, vehicle=record
    )
    assert handles.vehicle == as_vehicle(record)


def test_the_compiled_engine_flies_an_x_vehicle_with_a_lag_as_the_systems_do():
    """x500 ("x", 12.5 ms motors) through the first 3 s of planar_wall on
    both engines: the compiled chain (one integrator) drives the plant
    through the same rotor path (`add_rotor_path`)."""
    scenario = dataclasses.replace(
        parse_scenario(PLANAR_WALL), vehicle="x500", duration=3.0
    )
    systems = simulate(dataclasses.replace(scenario, engine="systems"))
    compiled = simulate(dataclasses.replace(scenario, engine="compiled"))
    assert compiled.metrics["engine"] == "compiled"
    end = [f.log["state"][-1, :3] for f in (systems, compiled)]
    assert np.linalg.norm(end[0] - scenario.start) > 1.0  # it flew
    np.testing.assert_allclose(end[0], end[1], atol=1e-4)


def test_a_model_file_from_the_command_line_flies_as_its_preset(tmp_path, capsys):
    """x500's shipped model as a !VehicleModel in a --set: read into the
    very record of the preset (the same flight), and a missing file is one
    line and exit status 2."""
    x500 = VEHICLES["x500"]
    model = (
        f"vehicle: !VehicleModel {{file: {vehicle_model_path('x500')}, "
        f"kF: {x500.kF!r}, kM: {x500.kM!r}, u_max: {x500.u_max!r}, "
        f"rotor_radius: {x500.rotor_radius!r}, layout: x, "
        f"motor_time_constant: {x500.motor_time_constant!r}}}"
    )
    scenario = load_scenario(PLANAR_WALL, [("--set", model)])
    got = scenario.vehicle
    for name in ("mass", "arm_length", "kF", "kM", "u_max", "motor_time_constant"):
        assert getattr(got, name) == pytest.approx(getattr(x500, name), rel=1e-12)
    assert got.inertia == pytest.approx(x500.inertia, rel=1e-12)
    assert got.layout == "x"
    missing = "vehicle: !VehicleModel {file: nope.urdf, kF: 1, kM: 0.02, u_max: 4, "
    missing += "rotor_radius: 0.1}"
    args = ["run", PLANAR_WALL, "--set", missing, "--out", str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "vehicle.file = 'nope.urdf': no such file" in err
