"""`NavigationConfig`, Drake's `Apply*Config` idiom for `add_navigation`:
it round-trips through Drake's YAML, a bad field is one line naming it,
and a config and the pinned keyword form fly the same flight to the bit.
Method aliases fly their method."""

import dataclasses
import os

import numpy as np
import pytest
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.examples import QuadrotorPlant
from pydrake.geometry import Box, GeometryInstance, ProximityProperties, SceneGraph
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from mfi_drake import (
    BuilderError,
    DepthCamera,
    Faults,
    NavigationConfig,
    NavigatorParams,
    ScenarioError,
    SphereSensor,
    add_navigation,
    apply_simulator_config,
    default_simulator_config,
    load_scenario,
    navigation_config,
    read_navigation_config,
    simulate,
    vehicle_model_path,
)
from mfi_drake.config.dynamic import Ground, RelativeVelocity
from mfi_drake.config.sensors import Gimbal
from mfi_drake.config.vehicles import VEHICLES
from mfi_drake.maths.escape import EscapeParams
from mfi_drake.world.motion import obstacles_move

from .conftest import SCENARIOS

START, GOAL = [0.0, 0.0, 1.5], [4.0, 0.3, 1.5]


def unusual_config() -> NavigationConfig:
    """A field of every kind away from its default."""
    return NavigationConfig(
        goal=[3.0, -1.0, 2.0],
        vehicle="crazyflie",
        method="gf",
        sensor=DepthCamera(width=80, height=60, gimbal=Gimbal(rate_deg_s=90.0)),
        navigator=NavigatorParams(c=3.0, v_d=0.8),
        escape=EscapeParams(stall_time=4.0),
        field_gains={"k": 2.5},
        faults=Faults(dropout_prob=0.1, seed=7),
        relative_velocity=RelativeVelocity(keep_right=30.0),
        ground=Ground(height=0.2),
        moving_obstacles=True,
    )


def test_a_config_round_trips_through_drakes_yaml():
    config = unusual_config()
    text = yaml_dump_typed(config)
    assert yaml_load_typed(schema=NavigationConfig, data=text) == config
    assert read_navigation_config(text) == config
    # Keys left out keep their defaults, as a scenario's do.
    assert read_navigation_config("goal: [1, 2, 3]") == NavigationConfig(
        goal=[1.0, 2.0, 3.0]
    )


def test_a_vehicle_model_is_read_relative_to_base_dir():
    """Oracle: the shipped model file of a preset reads back as its record."""
    preset = VEHICLES["crazyflie"]
    text = (
        "{goal: [1, 2, 3], vehicle: !VehicleModel {file: crazyflie.sdf, "
        f"kF: {preset.kF}, kM: {preset.kM}, u_max: {preset.u_max}, "
        f"rotor_radius: {preset.rotor_radius}, layout: {preset.layout}}}}}"
    )
    base_dir = os.path.dirname(vehicle_model_path("crazyflie"))
    vehicle = read_navigation_config(text, base_dir=base_dir).vehicle
    assert vehicle.mass == pytest.approx(preset.mass, rel=1e-12)
    assert vehicle.inertia == pytest.approx(preset.inertia, rel=1e-12)
    with pytest.raises(ScenarioError, match=r"^here: .*crazyflie.sdf"):
        read_navigation_config(text, "here", base_dir="/nonexistent")


BAD_YAML = {
    "goal: [1, 2]": r"^here: goal = \[1.0, 2.0\]: must be 3 finite numbers",
    "gaol: [1, 2, 3]": r"^here: gaol = \[1, 2, 3\]: unknown field of Navigation",
    "{goal: [1, 2, 3], navigator: {r_l: 1.0, r_b: 2.0}}": r"^here: navigator.r_b = 2",
    "{goal: [1, 2, 3], sensor: !Lidar {}}": r"^here: sensor = 'Lidar': must be tag",
    "{goal: [1, 2, 3], other_vehicles: -1}": r"^here: other_vehicles = -1: must be",
    "{goal: [1, 2, 3], faults: {dropout_prob: 2.0}}": r"^here: faults.dropout_prob",
}


@pytest.mark.parametrize("text", sorted(BAD_YAML))
def test_a_bad_field_is_one_line_naming_it(text):
    with pytest.raises(ScenarioError, match=BAD_YAML[text]) as error:
        read_navigation_config(text, "here")
    assert "\n" not in str(error.value)


def scene(builder: DiagramBuilder) -> SceneGraph:
    """The user's SceneGraph: one anchored crate between START and GOAL."""
    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    source = scene_graph.RegisterSource("user")
    crate = GeometryInstance(RigidTransform([2.0, 0.0, 1.5]), Box(0.4, 1, 3), "crate")
    crate.set_proximity_properties(ProximityProperties())
    scene_graph.RegisterAnchoredGeometry(source, crate)
    return scene_graph


def fly(add, seconds: float = 6.0):
    """(the diagram's systems, times, log) of the flight `add(builder,
    quadrotor, scene_graph)` sets up, from START."""
    builder = DiagramBuilder()
    scene_graph = scene(builder)
    quadrotor = builder.AddNamedSystem("quadrotor", QuadrotorPlant())
    handles = add(builder, quadrotor, scene_graph)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    apply_simulator_config(default_simulator_config(), simulator)
    context = simulator.get_mutable_context()
    handles.set_start(context, START)
    simulator.AdvanceTo(seconds)
    systems = [(s.get_name(), type(s).__name__) for s in diagram.GetSystems()]
    return systems, *handles.read_log(context)


@pytest.mark.parametrize("method", ["mfi", "gf"])
def test_a_config_and_the_keywords_fly_the_same_flight(method):
    keywords = {
        "goal": GOAL,
        "method": method,
        "sensor": SphereSensor(radius=2.5),
        "navigator": {"v_d": 0.8, "max_tilt": 0.3},
    }
    config = NavigationConfig(
        goal=GOAL,
        method=method,
        sensor=SphereSensor(radius=2.5),
        navigator=NavigatorParams(v_d=0.8, max_tilt=0.3),
    )
    by_keywords = fly(lambda b, q, sg: add_navigation(b, q, sg, **keywords))
    by_config = fly(lambda b, q, sg: add_navigation(b, q, sg, config=config))
    systems, times, log = by_config
    assert systems == by_keywords[0]
    assert np.array_equal(times, by_keywords[1])
    for name in log:
        assert np.array_equal(log[name], by_keywords[2][name]), name
    # It flew past the crate toward the goal, with the config's gains: the
    # default's flight is another.
    assert log["state"][-1, 0] > 2.2
    default = NavigationConfig(goal=GOAL, method=method, sensor=config.sensor)
    _, _, log_default = fly(lambda b, q, sg: add_navigation(b, q, sg, config=default))
    assert not np.array_equal(log_default["state"][-1], log["state"][-1])


def test_a_config_beside_its_fields_and_a_bad_config_are_named():
    builder = DiagramBuilder()
    scene_graph = scene(builder)
    quadrotor = builder.AddSystem(QuadrotorPlant())
    config = NavigationConfig(goal=GOAL)
    cases = {
        r"^goal = \[4.0, 0.3, 1.5\]: given with config": {"goal": GOAL},
        r"^faults = Faults\(.*\): given with config": {"faults": Faults()},
        r"^add_navigation: goal = \[1.0\]: must be 3": {
            "config": NavigationConfig(goal=[1.0])
        },
        r"^add_navigation: navigator = \{'c': 1.0\}: must be a NavigatorParams": {
            "config": dataclasses.replace(config, navigator={"c": 1.0})
        },
        r"^add_navigation: vehicle = 'blimp'": {
            "config": dataclasses.replace(config, vehicle="blimp")
        },
        r"^method = 'teleport'": {
            "config": dataclasses.replace(config, method="teleport")
        },
    }
    for message, arguments in cases.items():
        arguments = {"config": config} | arguments
        with pytest.raises(BuilderError, match=message):
            add_navigation(builder, quadrotor, scene_graph, **arguments)
    # Nothing was added: the same builder takes the good config.
    handles = add_navigation(builder, quadrotor, scene_graph, config=config)
    assert handles.config.method == "mfi" and handles.navigator.get_name() == (
        "navigator"
    )


@pytest.mark.parametrize("name", ["planar_wall", "moving_crossing"])
def test_a_scenarios_config_holds_its_navigation_fields(name):
    scenario = load_scenario(os.path.join(SCENARIOS, f"{name}.yaml"))
    config = navigation_config(scenario, "apf")
    assert config.moving_obstacles == obstacles_move(scenario)
    assert config.method == "apf"
    for field in dataclasses.fields(NavigationConfig):
        if hasattr(scenario, field.name) and field.name != "other_vehicles":
            assert getattr(config, field.name) == getattr(scenario, field.name)
    assert config.other_vehicles == len(scenario.other_vehicles)


def test_an_alias_flies_its_method_under_its_own_name():
    scenario = load_scenario(os.path.join(SCENARIOS, "planar_wall.yaml"))
    scenario = dataclasses.replace(scenario, duration=4.0)
    alias, method = simulate(scenario, "mfi-nc"), simulate(scenario, "mfi")
    assert (alias.method, method.method) == ("mfi-nc", "mfi")
    assert np.array_equal(alias.times, method.times)
    assert np.array_equal(alias.positions, method.positions)
