"""Input robustness of world files: `load_scenario` of a scenario whose
Gazebo world, included model, URDF or MJCF file (tests/data) was mutated
only ever returns a Scenario or raises ScenarioError with a one-line
message naming the scenario, never another exception (hypothesis, bounded
in time; docs/robustness.md has the counts of a longer run)."""

import copy
import os
import shutil
import tempfile
import warnings
import xml.etree.ElementTree as ET

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mfi_drake.config.scenario import Scenario, ScenarioError
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.world.validation import load_scenario

from .test_scenario_fuzz import mutate_lines

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
FUZZ = settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.function_scoped_fixture,
    ],
)
# The files mutated, relative to the copy of tests/data, and the world file
# a scenario names for each.
FILES = {
    "gazebo/worlds/yard.world": "gazebo/worlds/yard.world",
    "gazebo/models/gate/model.sdf": "gazebo/worlds/yard.world",
    "gazebo/models/gate/model.config": "gazebo/worlds/yard.world",
    "pybullet/table.urdf": "pybullet/table.urdf",
    "mujoco/scene.xml": "mujoco/scene.xml",
}
VALUES = [
    "",
    "nan",
    "-inf",
    "1e400",
    "-1",
    "0",
    "0 0 0 0 0 0 0",
    "1 2",
    "x",
    "model://gate",
    "model://nowhere",
    "package://p/x.obj",
    "../../../../../../etc/passwd",
    "/dev/null",
    "https://fuel.gazebosim.org/x",
    "&amp;",
    "&undefined;",
    "\u00e9\x01",
]
LINES = [
    "<include><uri>model://gate</uri></include>",
    "<include><uri>model://post</uri><name>post</name></include>",
    "<include><uri>model://nowhere</uri></include>",
    "<include><uri>../worlds/yard.world</uri></include>",
    "<include><uri>model://gate/model.sdf</uri></include>",
    "<include/>",
    '<pose rotation_format="quat_xyzw">0 0 0 0 0 0 0</pose>',
    '<pose degrees="true">1 2 3 1e300 0 0</pose>',
    "<pose>nan 0 0 0 0 0</pose>",
    "<state><model name='wall'><pose>1 2</pose></model></state>",
    "<state><insertions><model name='x'/></insertions></state>",
    "<state><deletions><name>gate</name></deletions></state>",
    "<collision name='c'><geometry><mesh><uri>/dev/null</uri></mesh></geometry>"
    "</collision>",
    "<collision name='c'><geometry><mesh><uri>model://crate/meshes/crate.obj</uri>"
    "<scale>0 0 0</scale></mesh></geometry></collision>",
    "<collision name='c'><geometry><plane><normal>0 0 0</normal></plane></geometry>"
    "</collision>",
    "<collision name='c'><geometry><heightmap/></geometry></collision>",
    "<model name='m'><link name='l'/></model>",
    "<model name='gate'><link name='l'/></model>",
    '<!DOCTYPE a [<!ENTITY x "xxxxxxxxxx">]>',
    "<![CDATA[ <model> ]]>",
    "<?xml version='1.0'?>",
    "<link name='l'><collision><geometry><box size='1 1 1'/></geometry></collision>"
    "</link>",
    "<joint name='j' type='floating'><parent link='baseLink'/><child link='x'/>"
    "</joint>",
    '<geom type="mesh" mesh="nothing"/>',
    '<body><freejoint/><geom type="box" size="0 0 0"/></body>',
    '<include file="scene.xml"/>',
]


@pytest.fixture(scope="module")
def workdir():
    """A copy of tests/data to mutate, and a scenario per world file."""
    with tempfile.TemporaryDirectory() as d:
        shutil.copytree(DATA, os.path.join(d, "data"))
        for world in set(FILES.values()):
            with open(os.path.join(d, world.replace("/", "_") + ".yaml"), "w") as f:
                f.write(
                    "name: fuzz\ngoal: [12, 0, 1.5]\nduration: 1\n"
                    f"world: data/{world}\nmodel_paths: [data/gazebo/models]\n"
                )
        yield d


def _tree_mutated(draw, text: str) -> str:
    """`text` with 1–3 of its elements' texts, attributes or children
    changed: well-formed XML, which reaches past the XML parser."""
    root = ET.fromstring(text)
    for _ in range(draw(st.integers(1, 3))):
        elements = list(root.iter())
        element = draw(st.sampled_from(elements))
        kind = draw(st.sampled_from(["text", "attribute", "delete", "copy", "add"]))
        if kind == "text":
            element.text = draw(st.sampled_from(VALUES))
        elif kind == "attribute":
            keys = [*element.attrib, "name", "concave", "type", "degrees"]
            element.set(draw(st.sampled_from(keys)), draw(st.sampled_from(VALUES)))
        elif kind == "add":
            snippet = draw(st.sampled_from(LINES))
            if snippet.startswith("<") and not snippet.startswith(("<!", "<?")):
                element.append(ET.fromstring(snippet))
        elif len(root):
            parents = [p for p in elements if len(p)]
            parent = draw(st.sampled_from(parents))
            child = draw(st.sampled_from(list(parent)))
            if kind == "delete":
                parent.remove(child)
            else:
                parent.append(copy.deepcopy(child))
    return ET.tostring(root, encoding="unicode")


@st.composite
def mutated(draw):
    """One of FILES with 1–3 line, token or character mutations, or 1–3
    mutations of its elements."""
    name = draw(st.sampled_from(sorted(FILES)))
    with open(os.path.join(DATA, name)) as f:
        text = f.read()
    if draw(st.booleans()):
        return name, _tree_mutated(draw, text)
    chars = "<>/=\"' &;!?-0123456789.eE+x\x00\u00e9"
    return name, mutate_lines(draw, text.splitlines(), VALUES, LINES, chars, "<>")


def check_loads_or_fails_cleanly(directory: str, name: str, text: str) -> None:
    target = os.path.join(directory, "data", name)
    with open(os.path.join(DATA, name), "rb") as f:
        original = f.read()
    with open(target, "wb") as f:
        f.write(text.encode("utf-8", "replace"))
    path = os.path.join(directory, FILES[name].replace("/", "_") + ".yaml")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScenarioWarning)
            scenario = load_scenario(path)
    except ScenarioError as e:
        message = str(e)
        assert message.startswith(path) and "\n" not in message, message
    else:
        assert isinstance(scenario, Scenario) and scenario.world == ""
    finally:
        with open(target, "wb") as f:
            f.write(original)


@FUZZ
@given(mutated())
def test_mutated_world_files_load_or_fail_cleanly(workdir, case):
    check_loads_or_fails_cleanly(workdir, *case)


@FUZZ
@given(st.binary(max_size=300))
def test_random_bytes_as_a_world_fail_cleanly(workdir, data):
    check_loads_or_fails_cleanly(
        workdir, "gazebo/worlds/yard.world", data.decode("latin-1")
    )


ONCE_CRASHED = {
    # Drake's MJCF parser follows the include until its stack overflows.
    "an mjcf that includes itself": (
        "mujoco/scene.xml",
        '<mujoco model="m"><worldbody><include file="scene.xml"/></worldbody></mujoco>',
        "data/mujoco/scene.xml:1: ",
    ),
    "an entity that expands": (
        "pybullet/table.urdf",
        '<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">]>\n<robot/>',
        "data/pybullet/table.urdf:2: not well-formed XML: entity 'a' declared",
    ),
}


@pytest.mark.parametrize("label", ONCE_CRASHED)
def test_inputs_that_once_crashed_the_loader_fail_cleanly(workdir, label):
    name, text, needle = ONCE_CRASHED[label]
    path = os.path.join(workdir, FILES[name].replace("/", "_") + ".yaml")
    target = os.path.join(workdir, "data", name)
    with open(target) as f:
        original = f.read()
    with open(target, "w") as f:
        f.write(text)
    try:
        with pytest.raises(ScenarioError) as error:
            load_scenario(path)
    finally:
        with open(target, "w") as f:
            f.write(original)
    message = str(error.value)
    assert "\n" not in message and needle in message, message
