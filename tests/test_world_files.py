"""Worlds from files (`world:`): an SDFormat or URDF file's static collision
geometries fly as the same obstacles written in the scenario would, travel
as obstacles, are named in errors, and bad files are one line each."""

import os
import textwrap

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.config import scenario_yaml
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.generator import self_contained
from mfi_drake.world.meshes import enclosed_volume
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.shapes import shape_mesh
from mfi_drake.world.validation import load_scenario

from .conftest import SCENARIOS

HEAD = """\
name: worlds
start: [0.0, 0.0, 1.5]
goal: [12.0, 0.0, 1.5]
duration: 25.0
"""

# One world, written as the scenario's obstacles ...
OBSTACLES = """\
obstacles:
  - {shape: !Box {size: [0.2, 2.5, 3.0]}, position: [3.0, -0.6, 1.5],
     rpy_deg: [0, 0, 20]}
  - {shape: !Sphere {radius: 0.5}, position: [5.5, 0.9, 1.6]}
  - {shape: !Cylinder {radius: 0.3, length: 3.0}, position: [7.0, -0.9, 1.5],
     rpy_deg: [10, 0, 0]}
  - {shape: !Capsule {radius: 0.2, length: 1.5}, position: [8.5, 0.6, 1.2],
     rpy_deg: [90, 0, 30]}
  - {shape: !Ellipsoid {radii: [0.5, 0.3, 0.4]}, position: [10.0, -0.5, 1.5],
     rpy_deg: [0, 15, 40]}
"""

# ... and as an SDFormat file: a model's pose and its link's compose.
SDF = """\
<?xml version="1.0"?>
<sdf version="1.9">
  <model name="scene">
    <static>true</static>
    <pose>1 0 0 0 0 0</pose>
    <link name="link">
      <pose>1 0 0 0 0 0</pose>
      <collision name="wall">
        <pose degrees="true">1 -0.6 1.5 0 0 20</pose>
        <geometry><box><size>0.2 2.5 3</size></box></geometry>
      </collision>
      <collision name="ball">
        <pose>3.5 0.9 1.6 0 0 0</pose>
        <geometry><sphere><radius>0.5</radius></sphere></geometry>
      </collision>
      <collision name="post">
        <pose degrees="true">5 -0.9 1.5 10 0 0</pose>
        <geometry><cylinder><radius>0.3</radius><length>3</length></cylinder></geometry>
      </collision>
      <collision name="log">
        <pose degrees="true">6.5 0.6 1.2 90 0 30</pose>
        <geometry><capsule><radius>0.2</radius><length>1.5</length></capsule></geometry>
      </collision>
      <collision name="bush">
        <pose degrees="true">8 -0.5 1.5 0 15 40</pose>
        <geometry><ellipsoid><radii>0.5 0.3 0.4</radii></ellipsoid></geometry>
      </collision>
      <visual name="not_an_obstacle">
        <geometry><sphere><radius>5</radius></sphere></geometry>
      </visual>
    </link>
  </model>
</sdf>
"""


def _write(tmp_path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return str(path)


def _world(tmp_path, sdf: str = SDF, extra: str = "", name: str = "w.sdf") -> str:
    """A scenario whose obstacles are the world file `name` holding `sdf`."""
    _write(tmp_path, name, sdf)
    return _write(tmp_path, "world.yaml", f"{HEAD}world: {name}\n{extra}")


def test_two_descriptions_of_one_world_fly_as_one(tmp_path):
    """The same five shapes as `obstacles:` and as an SDFormat world: equal
    obstacles (named after the file's model and geometry), and the same
    flight bit for bit."""
    written = load_scenario(_write(tmp_path, "obstacles.yaml", HEAD + OBSTACLES))
    world = load_scenario(_world(tmp_path))
    assert world.world == ""
    for a, b in zip(written.obstacles, world.obstacles, strict=True):
        assert (a.shape, a.position, a.rpy_deg) == (b.shape, b.position, b.rpy_deg)
    names = [o.name for o in world.obstacles]
    assert names == [
        f"world 'w.sdf' model 'scene' geometry '{g}'"
        for g in ("wall", "ball", "post", "log", "bush")
    ]
    a, b = simulate(written), simulate(world)
    assert a.metrics["success"] and a.metrics["min_clearance"] < 1.0  # it met them
    np.testing.assert_array_equal(a.times, b.times)
    for key in a.log:
        np.testing.assert_array_equal(a.log[key], b.log[key], err_msg=key)


def test_a_rotated_model_composes_its_poses(tmp_path):
    """A model yawed by 0.3 rad holding a sphere 2 m along its y: the sphere
    is at the rotated offset (closed form), and the distance from a point
    is to it."""
    sdf = SDF.replace(
        "<pose>1 0 0 0 0 0</pose>\n    <link", "<pose>4 0 1.5 0 0 0.3</pose>\n    <link"
    )
    sdf = sdf.replace(
        '<link name="link">\n      <pose>1 0 0 0 0 0</pose>', '<link name="link">'
    )
    sdf = sdf.replace("3.5 0.9 1.6 0 0 0", "0 2 0 0 0 0")
    scenario = load_scenario(_world(tmp_path, sdf, "goal: [12.0, -4.0, 1.5]\n"))
    (ball,) = [o for o in scenario.obstacles if o.name.endswith("'ball'")]
    expected = [4.0 - 2.0 * np.sin(0.3), 2.0 * np.cos(0.3), 1.5]
    np.testing.assert_allclose(ball.position, expected, atol=1e-12)
    (d,) = obstacle_distances(scenario, [[expected[0], expected[1], 2.7]])
    assert d == pytest.approx(0.7, abs=1e-9)


def test_a_goal_inside_a_world_geometry_names_it(tmp_path):
    path = _world(tmp_path)
    with pytest.raises(sc.ScenarioError) as info:
        load_scenario(path, [("--set", "goal: [5.5, 0.9, 1.7]")])
    message = str(info.value)
    assert "\n" not in message
    assert (
        "goal = [5.5, 0.9, 1.7]: is inside world 'w.sdf' model 'scene' "
        "geometry 'ball' (0.400 m deep)"
    ) in message


def test_an_obstacle_named_by_the_user_is_named_in_errors(tmp_path):
    obstacle = (
        '  - {shape: !Sphere {radius: 0.5}, position: [3, 0, 1.5], name: "the ball"}\n'
    )
    path = _write(tmp_path, "named.yaml", f"{HEAD}obstacles:\n{obstacle}")
    with pytest.raises(sc.ScenarioError, match="is inside the ball \\(0.500 m deep\\)"):
        load_scenario(path, [("--set", "goal: [3, 0, 1.5]")])
    with pytest.raises(sc.ScenarioError, match="name = 'a\\\\nb': must be one line"):
        load_scenario(path, [("--set", 'obstacles: [{name: "a\\nb"}]')])


def test_a_world_combines_with_obstacles_and_travels_as_them(tmp_path):
    """The scenario's own obstacles first, then the world's; written as YAML
    (what a sweep's worker receives) it reads back equal, with no path."""
    extra = "obstacles:\n  - {shape: !Sphere {radius: 0.3}, position: [6, 3, 1]}\n"
    scenario = load_scenario(_world(tmp_path, extra=extra))
    assert len(scenario.obstacles) == 6 and scenario.obstacles[0].name == ""
    text = scenario_yaml.scenario_to_yaml(scenario)
    assert "w.sdf'" in text and "world: ''" in text
    os.remove(tmp_path / "w.sdf")  # a worker cannot see the client's files
    back = scenario_yaml.scenario_from_yaml(text)
    assert (
        back.obstacles == scenario.obstacles
        and scenario_yaml.scenario_to_yaml(back) == text
    )


def test_a_sweep_layers_a_world_on_its_fields(tmp_path):
    """`self_contained` (what a sweep's fields go through after their
    overrides) resolves a world layered on a field."""
    _write(tmp_path, "w.sdf", SDF)
    field = sc.Scenario(name="field", goal=[12.0, 0.0, 1.5], base_dir=str(tmp_path))
    field.obstacles.append(sc.Obstacle(sc.Sphere(0.3), [6.0, 3.0, 1.0]))
    layered = scenario_yaml.layer(field, "world: w.sdf", "--set")
    flown = self_contained(layered)
    assert len(flown.obstacles) == 6 and flown.world == "" and flown.base_dir == ""


URDF = """\
<?xml version="1.0"?>
<robot name="shelf">
  <link name="world"/>
  <link name="base">
    <collision name="top">
      <origin xyz="0 0 1" rpy="0 0 0"/>
      <geometry><box size="1 2 0.1"/></geometry>
    </collision>
  </link>
  <joint name="fixed" type="fixed">
    <parent link="world"/><child link="base"/><origin xyz="3 0 0"/>
  </joint>
</robot>
"""


def test_a_urdf_welded_to_the_world_is_a_world(tmp_path):
    scenario = load_scenario(_world(tmp_path, URDF, name="shelf.urdf"))
    (top,) = scenario.obstacles
    assert top.shape == sc.Box(size=[1.0, 2.0, 0.1])
    assert top.position == [3.0, 0.0, 1.0] and top.rpy_deg == [0.0, 0.0, 0.0]
    assert top.name == "world 'shelf.urdf' model 'shelf' geometry 'top'"


def test_a_convex_mesh_of_a_world_is_its_hull_inline(tmp_path):
    """A mesh geometry declared convex, scaled by 0.5: its hull's vertices
    inline, scaled, so it reads no file once loaded; the canopy's distances
    are the file's."""
    canopy = os.path.join(SCENARIOS, "meshes", "canopy.obj")
    sdf = SDF.replace(
        'version="1.9"', 'version="1.9" xmlns:drake="http://drake.mit.edu"'
    )
    sdf = sdf.replace(
        "<sphere><radius>0.5</radius></sphere>",
        f"<mesh><uri>{canopy}</uri><scale>0.5 0.5 0.5</scale>"
        "<drake:declare_convex/></mesh>",
    )
    scenario = load_scenario(_world(tmp_path, sdf))
    mesh = scenario.obstacles[1]
    assert not mesh.shape.file and mesh.shape.scale == 1.0
    file_form = sc.Obstacle(sc.Convex(file=canopy, scale=0.5), mesh.position)
    points = [[5.5, 0.9, 2.6], [4.0, 0.9, 1.6], [5.5, 0.9, 1.6]]
    alone = sc.Scenario(obstacles=[file_form])
    expected = obstacle_distances(alone, points)
    got = obstacle_distances(sc.Scenario(obstacles=[mesh]), points)
    np.testing.assert_allclose(got, expected, atol=1e-12)


NO_COLLISION = SDF.split("<collision")[0] + "</link>\n  </model>\n</sdf>\n"
XACRO = (
    '<robot name="r"><link name="a"><collision><geometry><box size="1 1 1"/>'
    '</geometry></collision></link><link name="b"/><joint name="j" type="fixed">'
    '<origin xyz="$(optenv IMU_XYZ 0 0 1)"/><parent link="a"/><child link="b"/>'
    "</joint></robot>"
)
BAD_WORLDS = [
    ("missing", None, "w.sdf", "no such file"),
    ("not xml", "<sdf version='1.9'><model", "w.sdf", "w.sdf:1: not well-formed XML"),
    ("no collision", NO_COLLISION, "w.sdf", "holds no collision geometry"),
    ("suffix", SDF, "w.txt", "must be a Gazebo world or model (.world, .sdf)"),
    # An unprocessed xacro (PyBullet's husky): Drake's parser raises a
    # ValueError, named by its file here.
    ("xacro", XACRO, "w.urdf", "w.urdf: Expected 3 values for attribute xyz"),
]


@pytest.mark.parametrize(
    "label, text, name, needle", BAD_WORLDS, ids=[b[0] for b in BAD_WORLDS]
)
def test_a_bad_world_is_one_line_and_exit_2(
    tmp_path, capsys, label, text, name, needle
):
    path = _write(tmp_path, "world.yaml", f"{HEAD}world: {name}\n")
    if text is not None:
        _write(tmp_path, name, text)
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{path}: world = '{name}': {needle}" in err
    assert not out.exists()


def test_the_shipped_yard_flies_its_world():
    """scenarios/yard.yaml: its world's geometries after its own box (the
    hut's mesh as its convex pieces, which hold its volume), and a flight
    among them that reaches the goal without contact."""
    scenario = load_scenario(os.path.join(SCENARIOS, "yard.yaml"))
    kinds = [type(o.shape).__name__ for o in scenario.obstacles]
    hut = [o for o in scenario.obstacles if "model 'hut'" in o.name]
    assert len(hut) > 1
    assert kinds == ["Box", "Box", "Cylinder", "Convex"] + ["Convex"] * len(hut) + [
        "Sphere",
        "Capsule",
        "Ellipsoid",
    ]
    volume = sum(enclosed_volume(*shape_mesh(scenario, o.shape)) for o in hut)
    assert volume == pytest.approx(4 * 4 * 3 - 3 * 3 * 2.5 - 0.5 * 1 * 2, rel=0.02)
    flight = simulate(scenario, until_settled=True)
    assert flight.metrics["success"]
    assert 0.0 < flight.metrics["min_clearance"] < 1.0
