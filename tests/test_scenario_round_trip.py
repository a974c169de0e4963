"""Writing a scenario round-trips for every scenario the API builds: the
loader (`load_scenario`, which validates) reads back what `scenario_to_yaml`
(every field) and `generator.write_scenario` (the fields that differ from
the defaults) write, equal field for field to the scenario written. The
oracle compares the dataclass fields themselves, not the written text."""

import dataclasses
import glob
import os
import shutil

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydrake.systems.analysis import SimulatorConfig

from mfi_drake.config.scenario import Scenario
from mfi_drake.config.scenario_yaml import scenario_from_yaml, scenario_to_yaml
from mfi_drake.world import fleets, generator, goal_scenes
from mfi_drake.world.validation import least_goal_gap, load_scenario

from .conftest import SCENARIOS


def assert_same(loaded: Scenario, written: Scenario) -> None:
    """Every field equal, base_dir aside (where the file was read from);
    Drake's SimulatorConfig, which has no ==, attribute by attribute."""
    for f in dataclasses.fields(Scenario):
        a, b = getattr(loaded, f.name), getattr(written, f.name)
        if f.name == "simulator":
            for attribute in SimulatorConfig.__fields__:
                name = attribute.name
                assert getattr(a, name) == getattr(b, name), f"simulator.{name}"
        elif f.name != "base_dir":
            assert a == b, f.name


def to_yaml(scenario: Scenario, path: str) -> None:
    with open(path, "w") as f:
        f.write(scenario_to_yaml(scenario))


WRITERS = [to_yaml, generator.write_scenario]


def round_trips(scenario: Scenario, directory: str, writers=WRITERS) -> None:
    for write in writers:
        path = os.path.join(directory, f"{write.__name__}.yaml")
        write(scenario, path)
        loaded = load_scenario(path)
        assert loaded.base_dir == os.path.dirname(os.path.abspath(path))
        assert_same(loaded, scenario)


@pytest.mark.parametrize(
    "name", sorted(os.path.basename(p) for p in glob.glob(f"{SCENARIOS}/*.yaml"))
)
def test_shipped_scenarios_round_trip(tmp_path, name):
    # Beside a copy of the shipped directory: relative mesh files resolve
    # there. (`write_scenario` inlines mesh files' vertices: not the same
    # fields where there are some, so the full writer only.)
    here = shutil.copytree(SCENARIOS, tmp_path / "scenarios")
    scenario = load_scenario(os.path.join(SCENARIOS, name))
    round_trips(scenario, str(here), [to_yaml])


def test_the_text_carries_no_base_dir_and_the_reader_is_given_it():
    scene = dataclasses.replace(fleets.antipodal_circle(2), base_dir="/meshes")
    text = scenario_to_yaml(scene)
    assert "base_dir" not in text
    assert scenario_from_yaml(text).base_dir == ""
    assert_same(scenario_from_yaml(text, "/meshes"), scene)
    assert scenario_from_yaml(text, "/meshes").base_dir == "/meshes"


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    seed=st.integers(0, 10_000),
    index=st.integers(0, 100),
    density=st.sampled_from([0.0, 0.05, 0.1, 0.2]),
    kind=st.sampled_from(["field", "near_goal", "moving", "wall"]),
)
def test_generated_random_fields_round_trip(tmp_path, seed, index, density, kind):
    if kind == "wall":
        scene = generator.wall_field(seed, index)
    else:
        scene = generator.random_field(seed, index, density)
    if kind == "near_goal":
        scene = generator.near_goal(scene, seed, index, least_goal_gap() + 0.1)
    if kind == "moving":
        scene = generator.set_in_motion(scene, seed, index, 0.3, 0.5)
    round_trips(scene, str(tmp_path))


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    n=st.integers(1, 8),
    kind=st.sampled_from(["circle", "streams", "pairs"]),
    seed=st.integers(0, 1000),
)
def test_fleet_scenes_round_trip(tmp_path, n, kind, seed):
    if kind == "circle":
        scene = fleets.antipodal_circle(n)
    elif kind == "streams":
        scene = fleets.crossing_streams(n)
    else:
        field = generator.random_field(seed, 0, 0.05)
        scene = fleets.random_pairs(field, n, seed, 0)
    round_trips(scene, str(tmp_path))


@pytest.mark.parametrize("layout", goal_scenes.LAYOUTS)
def test_goal_scenes_round_trip(tmp_path, layout):
    gap = least_goal_gap() + 0.2
    round_trips(goal_scenes.goal_scene(layout, gap), str(tmp_path))
    without = goal_scenes.without_terminal_approach(goal_scenes.goal_scene(layout, gap))
    round_trips(without, str(tmp_path))


def test_the_compiled_engine_round_trips(tmp_path):
    scene = generator.random_field(3, 0, 0.05)
    round_trips(dataclasses.replace(scene, engine="compiled"), str(tmp_path))
