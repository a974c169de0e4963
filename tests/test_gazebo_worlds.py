"""World files as their tools ship them (tests/data): a Gazebo world of
nested `model://` includes with a <state> and a ground plane, a PyBullet
URDF of mass 0, a MuJoCo scene; each is the same scene written as
`obstacles:`, placed by `world_pose`, and a bad one is one line naming the
file and line, exit 2."""

import os
import shutil
import textwrap

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.flight.simulation import simulate
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.point_clouds import write_ply
from mfi_drake.world.sdformat import prepare
from mfi_drake.world.validation import load_scenario
from mfi_drake.world.world_files import world_obstacles

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
ROOT_DATA_MESHES = os.path.join(DATA, "meshes")
MODELS = os.path.join(DATA, "gazebo", "models")
YARD = os.path.join(DATA, "gazebo", "worlds", "yard.world")
HEAD = """\
name: shipped
start: [0.0, 0.0, 1.5]
goal: [12.0, 0.0, 1.5]
duration: 25.0
"""
# The yard as Gazebo shows it (its <state>: the crate raised 0.5 m above its
# model and yawed 0.5 rad, the wall moved to x = 10), written by hand.
YARD_OBSTACLES = {
    "gate::post_left": (sc.Cylinder(radius=0.3, length=3.0), [4, 1.1, 1.5], 0.0),
    "gate::post_right": (sc.Cylinder(radius=0.3, length=3.0), [4, -1.1, 1.5], 0.0),
    "gate": (sc.Box(size=[0.3, 2.6, 0.3]), [4, 0, 3.15], 0.0),
    "wall": (sc.Box(size=[0.2, 1.5, 3.0]), [10, -1.2, 1.5], 0.3),
}
CRATE = ([7.0, -1.5, 1.0], 0.5)  # a 1 m cube: centre, yaw (rad)


def _probe_points(seed: int, centre, spread: float, count: int = 80) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.asarray(centre) + rng.uniform(-spread, spread, (count, 3))


def _yaml(tmp_path, world: str, extra: str = "", name: str = "s.yaml") -> str:
    path = tmp_path / name
    path.write_text(f"{HEAD}world: {world}\n{textwrap.dedent(extra)}")
    return str(path)


def _yawed(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rotation(rpy_deg) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), written out (an oracle apart from
    Drake's RollPitchYaw)."""
    r, p, y = np.radians(rpy_deg)
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    return _yawed(y) @ Ry @ Rx


def _corners(obstacles: list[sc.Obstacle]) -> np.ndarray:
    """Every vertex of convex obstacles, in the world, sorted."""
    points = [
        np.asarray(o.shape.vertices) @ _rotation(o.rpy_deg).T + o.position
        for o in obstacles
    ]
    points = np.round(np.concatenate(points), 9)
    return points[np.lexsort(points.T[::-1])]


def _cube(centre, yaw: float, edge: float = 1.0) -> np.ndarray:
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    points = np.round(signs * edge / 2 @ _yawed(yaw).T + centre, 9)
    return points[np.lexsort(points.T[::-1])]


def _load_yard(tmp_path, extra: str = "") -> sc.Scenario:
    with pytest.warns(ScenarioWarning) as heard:
        scenario = load_scenario(
            _yaml(tmp_path, YARD, f"model_paths: [{MODELS}]\n{extra}")
        )
    (line,) = [str(w.message) for w in heard]
    assert "read past 3 plugins, 2 lights, 1 actor, 1 sensor, 6 visuals" in line
    assert "concave= on <mesh> (1×)" in line and "\n" not in line
    return scenario


def _by_model(scenario: sc.Scenario) -> dict[str, list[sc.Obstacle]]:
    found: dict[str, list[sc.Obstacle]] = {}
    for o in scenario.obstacles:
        model = o.name.split(" model ")[1].split("'")[1]
        found.setdefault(model, []).append(o)
    return found


def test_a_gazebo_world_is_the_scene_gazebo_shows(tmp_path):
    """Includes nested two deep, the model.config's highest SDFormat
    version, the include's name and pose, the <state>'s model and link
    poses, a relative mesh URI in its model's folder, the ground plane as
    the ground: each obstacle where the hand-written scene has it."""
    scenario = _load_yard(tmp_path)
    models = _by_model(scenario)
    assert sorted(models) == sorted([*YARD_OBSTACLES, "crate"])
    for model, (shape, position, yaw) in YARD_OBSTACLES.items():
        (o,) = models[model]
        assert o.shape == shape
        np.testing.assert_allclose(o.position, position, atol=1e-12)
        np.testing.assert_allclose(o.rpy_deg, [0, 0, np.degrees(yaw)], atol=1e-9)
    np.testing.assert_allclose(_corners(models["crate"]), _cube(*CRATE), atol=1e-9)
    assert scenario.ground == sc.Ground(height=-0.2)
    assert scenario.world == "" and scenario.world_pose == sc.WorldPose()


def test_the_gazebo_world_flies(tmp_path):
    """Through the gate (1.6 m between its posts) to the goal, never
    touching a geometry or the ground."""
    result = simulate(_load_yard(tmp_path))
    assert result.metrics["success"], result.metrics
    assert 0.0 < result.metrics["min_clearance"] < 1.0


@pytest.mark.parametrize("variable", ["GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH"])
def test_models_are_found_through_gazebos_variables(tmp_path, monkeypatch, variable):
    monkeypatch.setenv(variable, f"/nowhere:{MODELS}")
    with pytest.warns(ScenarioWarning):
        scenario = load_scenario(_yaml(tmp_path, YARD))
    expected = _load_yard(tmp_path)
    assert scenario.obstacles == expected.obstacles


def test_a_model_uri_with_three_slashes_names_the_model(tmp_path):
    """ "model:///post" (turtlebot3's table_marble writes its mesh so) is
    the model "post", as "model://post" is."""
    path = _world_file(tmp_path, "<include><uri>model:///post</uri></include>")
    (tmp_path / "elsewhere").mkdir()  # searched first, holds no "post"
    folders = [str(tmp_path / "elsewhere"), MODELS]
    (post,) = world_obstacles(path, "w.world", folders).obstacles
    assert post.shape == sc.Cylinder(radius=0.3, length=3.0)
    assert post.position == [0.0, 0.0, 1.5]


def test_a_package_uri_is_found_through_ros_package_path(tmp_path, monkeypatch):
    """package://PKG names the folder whose package.xml names PKG, however
    its folder is called."""
    package = tmp_path / "src" / "checkout"
    shutil.copytree(os.path.join(MODELS, "post"), package / "post")
    (package / "package.xml").write_text("<package><name>posts</name></package>")
    (tmp_path / "w.world").write_text(
        '<sdf version="1.6"><world name="w"><include>'
        "<uri>package://posts/post</uri><pose>3 0 0 0 0 0</pose>"
        "</include></world></sdf>"
    )
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    with pytest.warns(ScenarioWarning, match="1 visual"):
        (post,) = load_scenario(_yaml(tmp_path, "w.world")).obstacles
    assert post.shape == sc.Cylinder(radius=0.3, length=3.0)
    assert post.position == [3.0, 0.0, 1.5]


def test_a_fuel_uri_is_its_newest_download_or_a_folder_of_its_name(
    tmp_path, monkeypatch
):
    """Gazebo's Fuel cache holds versions 1 and 2 of a model: version 2 is
    read; a folder of the model's name in model_paths is read first."""
    cache = tmp_path / "fuel" / "fuel.gazebosim.org" / "openrobotics" / "models"
    shutil.copytree(os.path.join(MODELS, "post"), cache / "big post" / "2")
    shutil.copytree(os.path.join(MODELS, "gate"), cache / "big post" / "1")
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(tmp_path / "fuel"))
    uri = "https://fuel.gazebosim.org/1.0/OpenRobotics/models/Big%20Post"
    (tmp_path / "w.world").write_text(
        f'<sdf version="1.6"><world name="w"><include><uri>{uri}</uri>'
        "<pose>5 0 0 0 0 0</pose></include></world></sdf>"
    )
    with pytest.warns(ScenarioWarning):
        (post,) = load_scenario(_yaml(tmp_path, "w.world")).obstacles
    assert post.shape == sc.Cylinder(radius=0.3, length=3.0)
    assert post.position == [5.0, 0.0, 1.5]
    shutil.copytree(os.path.join(MODELS, "crate"), tmp_path / "models" / "Big Post")
    with pytest.warns(ScenarioWarning):
        scenario = load_scenario(_yaml(tmp_path, "w.world", "model_paths: [models]\n"))
    assert [o.name.split("model ")[1] for o in scenario.obstacles] == [
        "'crate' geometry 'collision' piece 0"  # the folder's model
    ]


def _world_file(tmp_path, models: str) -> str:
    (tmp_path / "w.world").write_text(
        f'<sdf version="1.9"><world name="w">{models}</world></sdf>'
    )
    return str(tmp_path / "w.world")


def test_what_gazebos_parser_reads_and_xml_forbids_is_read(tmp_path):
    """A comment before the XML declaration, "--" in a comment (Gazebo's
    own cafe.world and empty.sdf hold them): read, the lines kept."""
    (tmp_path / "w.world").write_text(
        "<!-- Usage: gz service --reqtype x -- see below -->\n"
        '<?xml version="1.0" ?>\n<sdf version="1.6">\n<world name="w">\n'
        "<model name='m'><pose>3 0 1 0 0 0</pose><link name='l'>\n"
        "<collision name='c'><geometry><box><size>1 1 x</size></box>\n"
        "</geometry></collision></link></model></world></sdf>\n"
    )
    with pytest.raises(ValueError, match=r"w.world:6: .*size"):
        world_obstacles(str(tmp_path / "w.world"), "w.world")


def test_a_plane_not_facing_up_is_a_slab_under_it(tmp_path):
    """A wall given as a plane at y = 3 facing -y: solid beyond it, the
    distances from points before it their distances to y = 3."""
    path = _world_file(
        tmp_path,
        '<model name="m"><static>true</static><link name="l"><collision name="c">'
        "<pose>0 3 0 0 0 0</pose><geometry><plane><normal>0 -1 0</normal>"
        "</plane></geometry></collision></link></model>",
    )
    scenario = sc.Scenario(obstacles=world_obstacles(path, "w.world").obstacles)
    points = [[0, 0, 1.5], [5, 2, -4], [-7, 2.9, 10]]
    np.testing.assert_allclose(
        obstacle_distances(scenario, points), [3.0, 1.0, 0.1], atol=1e-9
    )


def test_a_link_posed_relative_to_a_joint_is_where_the_joint_puts_it(tmp_path):
    """Joints are read past, but the frames they define stay: l2 is 0.5 m
    above the joint, which is 1 m along l1's x (l1 at x = 2)."""
    path = _world_file(
        tmp_path,
        '<model name="m"><pose>2 0 0 0 0 0</pose><link name="l1"/>'
        '<link name="l2"><pose relative_to="j">0 0 0.5 0 0 0</pose>'
        '<collision name="c"><geometry><sphere><radius>0.2</radius></sphere>'
        '</geometry></collision></link><joint name="j" type="revolute">'
        '<pose relative_to="l1">1 0 0 0 0 0</pose><parent>l1</parent>'
        "<child>l2</child><axis><xyz>0 0 1</xyz></axis></joint></model>",
    )
    (ball,) = world_obstacles(path, "w.world").obstacles
    np.testing.assert_allclose(ball.position, [3.0, 0.0, 0.5], atol=1e-12)


def test_joints_gazebo_classic_allows_and_sdformat_refuses_are_read_past(tmp_path):
    """Gazebo's own model collection holds joints Drake refuses: one named
    as its child link, one named "world", one whose child names nothing.
    Each is read past (said in the notes) and the links stay where they
    are; a joint beside them whose frame a pose names still places it."""
    ball = "<geometry><sphere><radius>0.2</radius></sphere></geometry>"
    path = _world_file(
        tmp_path,
        '<model name="m"><pose>2 0 0 0 0 0</pose>'
        f'<link name="wheel"><pose>0 1 0 0 0 0</pose><collision name="cw">{ball}'
        "</collision></link>"
        f'<link name="l2"><pose relative_to="j">0 0 0.5 0 0 0</pose>'
        f'<collision name="c2">{ball}</collision></link>'
        '<joint name="wheel" type="revolute"><parent>l2</parent>'
        "<child>wheel</child></joint>"
        '<joint name="world" type="fixed"><parent>world</parent>'
        "<child>l2</child></joint>"
        '<joint name="lost" type="fixed"><parent>l2</parent>'
        "<child>gone::link</child></joint>"
        '<joint name="j" type="revolute"><pose relative_to="wheel">1 0 0 0 0 0</pose>'
        "<parent>wheel</parent><child>l2</child></joint></model>",
    )
    world = world_obstacles(path, "w.world")
    got = {o.name.split("'")[-2]: o.position for o in world.obstacles}
    np.testing.assert_allclose(got["cw"], [2.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(got["c2"], [3.0, 1.0, 0.5], atol=1e-12)
    assert world.notes == "read past 3 joints"


def test_an_xml_declaration_after_a_blank_line_is_read_with_its_encoding(tmp_path):
    """A blank line before the XML declaration (Gazebo's lunar pit model):
    read, its encoding (Latin-1 here) kept, the lines unchanged."""
    text = (
        '\n<?xml version="1.0" encoding="ISO-8859-1"?>\n<!-- caf\xe9 -->\n'
        '<sdf version="1.6"><world name="w">\n'
        "<model name='m'><link name='l'>\n"
        "<collision name='c'><geometry><box><size>1 1 x</size></box>\n"
        "</geometry></collision></link></model></world></sdf>\n"
    )
    (tmp_path / "w.world").write_bytes(text.encode("latin-1"))
    with pytest.raises(ValueError, match=r"w.world:6: .*size"):
        world_obstacles(str(tmp_path / "w.world"), "w.world")


def test_a_light_alone_says_so_and_a_terrain_without_its_image_names_it(tmp_path):
    """A file of a light alone (Gazebo's sun; Drake refused it: no <model>
    or <world>) says what it read past; a terrain whose image is missing,
    or no image, is one line naming the file's line."""
    (tmp_path / "sun.sdf").write_text(
        '<sdf version="1.5"><light type="directional" name="sun"/></sdf>'
    )
    with pytest.raises(
        ValueError, match=r"^holds no collision geometry \(read past 1 light\)$"
    ):
        world_obstacles(str(tmp_path / "sun.sdf"), "sun.sdf")
    heightmap = (
        '<model name="pit"><static>true</static><link name="l">'
        '<collision name="c"><geometry><heightmap><uri>pit.png</uri>'
        "<size>10 10 2</size></heightmap></geometry></collision></link></model>"
    )
    path = _world_file(tmp_path, heightmap)
    with pytest.raises(ValueError, match=r"w.world:1: heightmap 'pit.png': no such"):
        world_obstacles(path, "w.world")
    (tmp_path / "pit.png").write_text("version https://git-lfs.github.com/spec/v1\n")
    with pytest.raises(ValueError, match=r"pit.png: not readable as an image"):
        world_obstacles(path, "w.world")


def test_a_state_inserts_and_deletes_models(tmp_path):
    """Gazebo's <insertions> add a model and <deletions> remove one."""
    with open(YARD) as f:
        text = f.read()
    state = """<state world_name="yard">
      <insertions><model name="cube"><pose>2 2 1 0 0 0</pose><link name="l">
        <collision name="c"><geometry><box><size>1 1 1</size></box></geometry>
        </collision></link></model></insertions>
      <deletions><name>wall</name><name>crate</name></deletions>"""
    (tmp_path / "y.world").write_text(text.replace('<state world_name="yard">', state))
    with pytest.warns(ScenarioWarning):
        scenario = load_scenario(
            _yaml(tmp_path, "y.world", f"model_paths: [{MODELS}]\n")
        )
    models = _by_model(scenario)
    assert "wall" not in models and "crate" not in models
    (cube,) = models["cube"]
    assert cube.shape == sc.Box(size=[1.0, 1.0, 1.0]) and cube.position == [2, 2, 1]


def test_a_scenarios_own_ground_is_kept_and_said(tmp_path):
    with pytest.warns(ScenarioWarning) as heard:
        scenario = load_scenario(
            _yaml(tmp_path, YARD, f"model_paths: [{MODELS}]\nground: {{height: 0.1}}\n")
        )
    assert scenario.ground == sc.Ground(height=0.1)
    assert "ground plane at z = -0.2 m is not read" in str(heard[0].message)


def test_world_pose_places_a_gazebo_world(tmp_path):
    """Every obstacle of the posed world is the unposed one moved by the
    pose (rotation written out by hand); its ground rises with it."""
    pose = {"position": [1.0, -2.0, 0.5], "rpy_deg": [0.0, 0.0, 30.0]}
    plain = _load_yard(tmp_path)
    posed = _load_yard(tmp_path, f"world_pose: {pose}\n")
    R = _rotation(pose["rpy_deg"])
    for a, b in zip(plain.obstacles, posed.obstacles, strict=True):
        assert a.shape == b.shape and a.name == b.name
        np.testing.assert_allclose(b.position, R @ a.position + [1, -2, 0.5])
        np.testing.assert_allclose(_rotation(b.rpy_deg), R @ _rotation(a.rpy_deg))
    assert posed.ground == sc.Ground(height=-0.2 + 0.5)


def test_a_pybullet_table_of_mass_0_stands_where_world_pose_puts_it(tmp_path):
    """One link of mass 0 and no joint: static, as PyBullet holds it; its
    drawer's prismatic joint held at zero; placed at x = 5, turned 90°."""
    table = os.path.join(DATA, "pybullet", "table.urdf")
    extra = "world_pose: {position: [5, 0, 0], rpy_deg: [0, 0, 90]}\n"
    with pytest.warns(ScenarioWarning, match="read past 1 visual"):
        scenario = load_scenario(_yaml(tmp_path, table, extra))
    # Written by hand: (x, y, z) in the table -> (5 - y, x, z), yawed 90°.
    expected = [
        ([1.5, 1.0, 0.05], [5.0, 0.0, 0.6]),
        ([0.1, 0.1, 0.58], [5.4, -0.65, 0.29]),
        ([0.1, 0.1, 0.58], [4.6, 0.65, 0.29]),
        ([0.5, 0.8, 0.1], [5.0, 0.3, 0.5]),
    ]
    assert len(scenario.obstacles) == len(expected)
    for o, (size, position) in zip(scenario.obstacles, expected, strict=True):
        assert o.shape == sc.Box(size=size)
        np.testing.assert_allclose(o.position, position, atol=1e-12)
        np.testing.assert_allclose(o.rpy_deg, [0, 0, 90], atol=1e-9)


def test_a_mujoco_scene_is_its_geoms(tmp_path):
    """MJCF half sizes, a capsule from `fromto`, a mesh's hull (as MuJoCo
    collides it), a free body and a hinged one where they start, the
    visual-only marker not an obstacle, the floor plane the ground."""
    scene = os.path.join(DATA, "mujoco", "scene.xml")
    with pytest.warns(ScenarioWarning, match="Drake warnings"):
        scenario = load_scenario(_yaml(tmp_path, scene))
    expected = {
        "pillar": (sc.Cylinder(radius=0.3, length=3.0), [4, 1, 1.5], 0),
        "block": (sc.Box(size=[1.0, 0.8, 2.0]), [6, -1, 1], 30),
        "ball": (sc.Sphere(radius=0.4), [8, 0.5, 1.6], 0),
        "arm": (sc.Capsule(radius=0.2, length=2.0), [10, -0.8, 1.2], 0),
    }
    found = {o.name.split("geometry ")[1].strip("'"): o for o in scenario.obstacles}
    # A mesh: its hull, one piece (named as a world file's mesh pieces are),
    # the crate's 1 m cube.
    crate = found.pop("crate' piece 0")
    np.testing.assert_allclose(
        _corners([crate]), _cube([2, -1.5, 1], np.radians(20)), atol=1e-9
    )
    assert sorted(found) == sorted(expected)
    for name, (shape, position, yaw) in expected.items():
        assert found[name].shape == shape
        np.testing.assert_allclose(found[name].position, position, atol=1e-12)
        np.testing.assert_allclose(found[name].rpy_deg, [0, 0, yaw], atol=1e-9)
    assert scenario.ground == sc.Ground(height=0.0)


def test_a_mujoco_file_pybullet_ships_is_still_its_geoms(tmp_path):
    """PyBullet's MJCF files as it ships them: no model name, a joint of a
    type only PyBullet reads ("fixed"), an actuator and a tendon naming
    joints Drake never made. Each body is where the file puts it: the
    geoms' poses written by hand."""
    (tmp_path / "m.xml").write_text(
        "<mujoco><option timestep='0.01'/><worldbody>"
        "<geom name='floor' type='plane' size='5 5 0.1'/>"
        "<body name='torso' pos='2 0 1'><joint name='root' type='fixed'/>"
        "<geom name='torso' type='sphere' size='0.3'/>"
        "<body name='leg' pos='0 0.5 0'><joint name='hip' type='hinge'/>"
        "<geom name='leg' type='box' pos='0 0 -0.4' size='0.1 0.1 0.4'/>"
        "</body></body></worldbody>"
        "<tendon><fixed name='t'><joint coef='1' joint='knee'/></fixed></tendon>"
        "<actuator><motor joint='wrist' gear='10'/></actuator></mujoco>"
    )
    world = world_obstacles(str(tmp_path / "m.xml"), "m.xml")
    found = {o.name.split("geometry ")[1].strip("'"): o for o in world.obstacles}
    assert found["torso"].shape == sc.Sphere(radius=0.3)
    np.testing.assert_allclose(found["torso"].position, [2.0, 0.0, 1.0], atol=1e-12)
    assert found["leg"].shape == sc.Box(size=[0.2, 0.2, 0.8])
    np.testing.assert_allclose(found["leg"].position, [2.0, 0.5, 0.6], atol=1e-12)
    assert world.ground == 0.0 and world.notes.startswith("read past 2 joints"), (
        world.notes
    )
    # Named "" (Drake's check failed: the process exited): named by its file.
    (tmp_path / "e.xml").write_text(
        '<mujoco model=""><worldbody><geom type="sphere" size="1"/></worldbody>'
        "</mujoco>"
    )
    (ball,) = world_obstacles(str(tmp_path / "e.xml"), "e.xml").obstacles
    assert ball.shape == sc.Sphere(radius=1.0)


def test_a_pybullet_urdf_as_shipped_loads(tmp_path):
    """PyBullet's leniencies: a robot named "" (its humanoid.urdf), an
    implicit plane (plane_implicit.urdf: the ground), a mesh scale of four
    numbers (racecar: the first three read, as PyBullet does), a link
    named "world" (its grippers), two collisions of one name."""
    box = os.path.join(ROOT_DATA_MESHES, "box_binary.stl")  # 1 × 2 × 0.5 m
    (tmp_path / "r.urdf").write_text(
        '<robot name=""><link name="world"><collision><origin xyz="0 0 -1"/>'
        '<geometry><plane normal="0 0 1"/></geometry></collision></link>'
        '<link name="base"><collision name="c"><origin xyz="3 0 1"/><geometry>'
        '<box size="1 1 1"/></geometry></collision><collision name="c">'
        f'<origin xyz="6 0 1"/><geometry><mesh filename="{box}" scale="2 1 1 1"/>'
        "</geometry></collision></link>"
        '<joint name="j" type="fixed"><parent link="world"/><child link="base"/>'
        "</joint></robot>"
    )
    world = world_obstacles(str(tmp_path / "r.urdf"), "r.urdf")
    assert world.ground == -1.0
    cube, *pieces = world.obstacles
    assert cube.shape == sc.Box(size=[1.0, 1.0, 1.0]) and cube.position == [3, 0, 1]
    # The mesh at scale (2, 1, 1): x over [6, 8], y over [0, 2], z over [1, 1.5].
    corners = _corners(pieces)
    np.testing.assert_allclose(corners.min(axis=0), [6.0, 0.0, 1.0], atol=1e-9)
    np.testing.assert_allclose(corners.max(axis=0), [8.0, 2.0, 1.5], atol=1e-9)


def test_a_gazebo_link_named_world_and_repeated_collision_names_load(tmp_path):
    """SDFormat as PyBullet's grippers and Gazebo's kiva shelf ship it: a
    link named "world", and one link's collisions all named alike: each
    collision flies where the file puts it."""
    ball = "<geometry><sphere><radius>0.2</radius></sphere></geometry>"
    path = _world_file(
        tmp_path,
        '<model name="m"><link name="world"><collision name="c">'
        f"<pose>1 0 0 0 0 0</pose>{ball}</collision></link>"
        '<link name="shelf"><collision name="pod"><pose>2 0 0 0 0 0</pose>'
        f'{ball}</collision><collision name="pod"><pose>3 0 0 0 0 0</pose>'
        f"{ball}</collision></link></model>",
    )
    world = world_obstacles(path, "w.world")
    xs = sorted(o.position[0] for o in world.obstacles)
    assert xs == [1.0, 2.0, 3.0]


def _heightmap_world(tmp_path, pixels, pose="0 0 0 0 0 0") -> str:
    """A world of one terrain: `pixels` (rows, columns; uint8 or uint16) as
    its PNG, 16 × 16 × 4 m centred at (1, 2, 0.5) in a model at `pose`."""
    from PIL import Image

    Image.fromarray(pixels).save(tmp_path / "hill.png")
    return _world_file(
        tmp_path,
        f'<model name="terrain"><static>true</static><pose>{pose}</pose>'
        '<link name="l"><collision name="c"><geometry><heightmap>'
        "<uri>hill.png</uri><size>16 16 4</size><pos>1 2 0.5</pos>"
        "<texture><diffuse>x.png</diffuse></texture>"
        "</heightmap></geometry></collision></link></model>",
    )


def _extent(obstacles: list[sc.Obstacle]) -> np.ndarray:
    """[[x, y, z] lowest, [x, y, z] highest] over boxes turned 0° or 90°."""
    lows, highs = [], []
    for o in obstacles:
        half = np.abs(_rotation(o.rpy_deg)) @ np.asarray(o.shape.size) / 2
        lows.append(np.asarray(o.position) - half)
        highs.append(np.asarray(o.position) + half)
    return np.array([np.min(lows, axis=0), np.max(highs, axis=0)])


def test_a_heightmap_is_its_ground_and_columns_as_gazebo_reads_it(tmp_path):
    """Gazebo's reading, by hand: 17 × 17 pixels over 16 × 16 m (a pixel a
    metre), the image's top row at +y; one white pixel (row 4, column 12)
    is x = 1 − 8 + 12 = 5, y = 2 + 8 − 4 = 6, 4 m above pos z = 0.5. The
    four cells around it are columns 1 × 1 × 4 m standing on the ground at
    0.5; the flat cells have none. Placed by its model (x = 10, z = 1, yaw
    90°: (x, y) → (10 − y, x)), and the same from a 16-bit image."""
    pixels = np.zeros((17, 17), np.uint8)
    pixels[4, 12] = 255
    world = world_obstacles(_heightmap_world(tmp_path, pixels), "w.world")
    assert world.ground == 0.5 and len(world.obstacles) == 4
    assert all(o.shape.size == [1.0, 1.0, 4.0] for o in world.obstacles)
    np.testing.assert_allclose(
        _extent(world.obstacles), [[4, 5, 0.5], [6, 7, 4.5]], atol=1e-12
    )
    wide = np.zeros((17, 17), np.uint16)
    wide[4, 12] = 32768  # half of 16-bit's largest: 2 m
    placed = world_obstacles(
        _heightmap_world(tmp_path, wide, "10 0 1 0 0 1.5707963267948966"), "w"
    )
    assert placed.ground == pytest.approx(1.5) and len(placed.obstacles) == 4
    np.testing.assert_allclose(
        _extent(placed.obstacles),
        [[3, 4, 1.5], [5, 6, 1.5 + 4 * 32768 / 65535]],
        atol=1e-9,
    )


def test_a_terrain_is_flown_over_or_round(tmp_path):
    """A hill 2.4 m high across the way (a ridge of the image's middle
    columns): the vehicle reaches the goal beyond it without contact."""
    pixels = np.zeros((17, 17), np.uint8)
    pixels[2:15, 7:10] = 153  # 0.6 of 4 m, x over [−0.5, 2.5] before placing
    path = _heightmap_world(tmp_path, pixels, "3 -2 -0.5 0 0 0")
    scenario = load_scenario(_yaml(tmp_path, path))
    assert scenario.ground == sc.Ground(height=0.0)
    flight = simulate(scenario)
    assert flight.metrics["success"] and flight.metrics["min_clearance"] > 0.0


def test_a_polyline_is_its_extruded_outline_exactly(tmp_path):
    """Gazebo's <polyline>: an L of 6 corners (clockwise, its first corner
    repeated at the end) extruded 2 m, in a model at (5, 0, 1): 4 triangle
    prisms whose distances from points around it are those of the two
    boxes the L is made of (the oracle); its hull's would not be. A
    polyline that crosses itself, or of no height, is one line naming the
    file's line."""
    corners = ["0 0", "0 2", "1 2", "1 1", "2 1", "2 0", "0 0"]
    points = "".join(f"<point>{c}</point>" for c in corners)
    path_text = (
        '<model name="l"><static>true</static><pose>5 0 1 0 0 0</pose>'
        '<link name="k"><collision name="c"><geometry><polyline>'
        f"{points}<height>2</height></polyline></geometry></collision></link></model>"
    )
    path = _world_file(tmp_path, path_text)
    world = world_obstacles(path, "w.world")
    assert len(world.obstacles) == 4 and world.notes == ""
    boxes = [
        sc.Obstacle(shape=sc.Box(size=[2.0, 1.0, 2.0]), position=[6.0, 0.5, 2.0]),
        sc.Obstacle(shape=sc.Box(size=[1.0, 1.0, 2.0]), position=[5.5, 1.5, 2.0]),
    ]
    probes = _probe_points(3, [6.0, 1.0, 2.0], 2.5)
    expected = np.asarray(obstacle_distances(sc.Scenario(obstacles=boxes), probes))
    outside = expected > 0.0
    got = np.asarray(obstacle_distances(sc.Scenario(obstacles=world.obstacles), probes))
    assert outside.sum() > 40
    np.testing.assert_allclose(got[outside], expected[outside], atol=1e-9)
    crossed = "".join(f"<point>{c}</point>" for c in ["0 0", "3 2", "3 0", "0 1"])
    bow = _world_file(
        tmp_path,
        '<model name="b"><static>true</static><link name="k"><collision name="c">'
        f"<geometry><polyline>{crossed}<height>1</height></polyline></geometry>"
        "</collision></link></model>",
    )
    with pytest.raises(ValueError, match=r"w.world:1: .*must not cross itself"):
        world_obstacles(bow, "w.world")
    flat = _world_file(
        tmp_path, path_text.replace("<height>2</height>", "<height>0</height>")
    )
    with pytest.raises(ValueError, match=r"w.world:1: a polyline's height must be pos"):
        world_obstacles(flat, "w.world")


def test_world_pose_places_a_cloud(tmp_path):
    """A map's points are the unposed map's, moved by the pose."""
    rng = np.random.default_rng(3)
    write_ply(str(tmp_path / "m.ply"), rng.uniform([2, -2, 0], [10, 2, 3], (500, 3)))
    plain = load_scenario(_yaml(tmp_path, "m.ply"))
    extra = "world_pose: {position: [0.5, 1.0, -0.2], rpy_deg: [10, 0, 45]}\n"
    posed = load_scenario(_yaml(tmp_path, "m.ply", extra, name="posed.yaml"))
    R = _rotation([10, 0, 45])
    moved = np.asarray(plain.map_points) @ R.T + [0.5, 1.0, -0.2]
    np.testing.assert_allclose(posed.map_points, moved, atol=1e-12)


def test_a_dae_collision_mesh_in_centimetres_is_the_crate(tmp_path):
    """The crate as a COLLADA cube of 200 cm, scaled 0.5: a 1 m cube."""
    (tmp_path / "w.world").write_text(
        '<sdf version="1.6"><world name="w"><include><uri>model://crate_cm</uri>'
        "<pose>7 -1.5 1 0 0 0.5</pose></include></world></sdf>"
    )
    scenario = load_scenario(_yaml(tmp_path, "w.world", f"model_paths: [{MODELS}]\n"))
    np.testing.assert_allclose(_corners(scenario.obstacles), _cube(*CRATE), atol=1e-9)


BROKEN = {
    # A model nobody has: named, with the folders searched and the line.
    "missing include": (
        "<include>\n<uri>model://nowhere</uri>\n</include>",
        "w.world:4: model 'nowhere' (model://nowhere) not found in: " + MODELS,
    ),
    "bad xml": ("<model name='m'>\n<link>\n</model>", "w.world:6: not well-formed XML"),
    # Drake's own cause, at the line of the element in this file.
    "drake's cause": (
        "<model name='m'>\n<link name='l'><collision name='c'>\n"
        "<geometry><box><size>1 1</size></box></geometry>\n</collision></link></model>",
        "w.world:6: ",
    ),
    "fuel model not downloaded": (
        "<include><uri>https://fuel.gazebosim.org/1.0/x/models/y</uri></include>",
        "w.world:4: Fuel model 'y' (https://fuel.gazebosim.org/1.0/x/models/y; "
        f"Gazebo downloads it) not found in: {MODELS}, ",
    ),
}


@pytest.mark.parametrize("label", BROKEN)
def test_a_broken_world_is_one_line_naming_its_line_and_exit_2(tmp_path, capsys, label):
    body, needle = BROKEN[label]
    (tmp_path / "w.world").write_text(
        f'<?xml version="1.0"?>\n<sdf version="1.6">\n<world name="w">\n{body}\n'
        "</world>\n</sdf>\n"
    )
    path = _yaml(tmp_path, "w.world", f"model_paths: [{MODELS}]\n")
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{path}: world = 'w.world': {needle}" in err
    assert not out.exists()


def test_a_thousand_geometries_and_a_ground_plane_load(tmp_path):
    """Drake's SceneGraph crashed (exit 139) registering a half space among
    ~1000 geometries (FCL's broadphase): a plane reaches Drake as a
    placeholder box, and the world loads with its ground (3k_shapes.sdf of
    Gazebo's examples crashed so)."""
    centres = np.random.default_rng(7).uniform(20, 60, (1000, 2)).round(3)
    boxes = "".join(
        f'<model name="b{k}"><pose>{x} {y} 1 0 0 0</pose><link name="l">'
        '<collision name="c"><geometry><cylinder><radius>0.1</radius>'
        "<length>2</length></cylinder></geometry></collision></link></model>"
        for k, (x, y) in enumerate(centres)
    )
    (tmp_path / "w.world").write_text(
        f'<sdf version="1.6"><world name="w">{boxes}<include>'
        "<uri>model://ground_plane</uri></include></world></sdf>"
    )
    path = str(tmp_path / "w.world")
    assert not any("<plane>" in text for text in prepare(path, [MODELS]).texts)
    world = world_obstacles(path, "w.world", [MODELS])  # (validation: issue 49b)
    assert world.ground == 0.0
    # Parsed in parts of 250 models (Drake's parse grows as n²): every
    # model once, where it was written.
    found = {o.name.split("'")[3]: o.position for o in world.obstacles}
    assert found == {f"b{k}": [x, y, 1.0] for k, (x, y) in enumerate(centres)}


def test_an_include_of_a_light_only_is_read_past_as_a_light(tmp_path):
    """Fuel's "Sun", included by many worlds written for Gazebo Sim
    (turtlebot3_gazebo's), is an SDFormat file of one <light> and no
    <model>: read past and counted, not refused."""
    sun = tmp_path / "models" / "sun"
    sun.mkdir(parents=True)
    (sun / "model.sdf").write_text(
        '<sdf version="1.6"><light type="directional" name="sun">'
        "<pose>0 0 10 0 0 0</pose></light></sdf>"
    )
    (tmp_path / "w.world").write_text(
        '<sdf version="1.6"><world name="w"><include><uri>model://sun</uri>'
        "</include><model name='wall'><static>true</static><link name='l'>"
        "<collision name='c'><pose>6 0 1.5 0 0 0</pose><geometry><box>"
        "<size>0.2 4 3</size></box></geometry></collision></link></model>"
        "</world></sdf>"
    )
    extra = f"model_paths: [{tmp_path / 'models'}]\n"
    with pytest.warns(ScenarioWarning) as heard:
        scenario = load_scenario(_yaml(tmp_path, "w.world", extra))
    (line,) = [str(w.message) for w in heard]
    assert "read past 1 light" in line and "\n" not in line
    (wall,) = scenario.obstacles
    assert wall.shape.size == [0.2, 4.0, 3.0] and wall.position == [6.0, 0.0, 1.5]


def test_fuels_sun_and_ground_plane_not_downloaded_are_stood_in_for(
    tmp_path, monkeypatch
):
    """A world including Fuel's Sun and Ground Plane (any Fuel host, the
    name's case as written) on a machine whose Fuel caches are empty loads:
    the Sun is a light read past, the Ground Plane the scenario's ground at
    its include's height, and the line says the stand-ins were read. A
    model of another owner is still refused (the broken-world cases)."""
    monkeypatch.setenv("HOME", str(tmp_path))  # no ~/.gz/fuel
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(tmp_path / "empty"))
    (tmp_path / "w.world").write_text(
        '<sdf version="1.9"><world name="w">'
        "<include><uri>https://fuel.gazebosim.org/1.0/OpenRobotics/models/Sun"
        "</uri></include><include><uri>https://fuel.ignitionrobotics.org/1.0/"
        "openrobotics/models/ground plane</uri><pose>0 0 -1 0 0 0</pose>"
        "</include><model name='wall'><static>true</static><link name='l'>"
        "<collision name='c'><pose>6 0 1.5 0 0 0</pose><geometry><box>"
        "<size>0.2 4 3</size></box></geometry></collision></link></model>"
        "</world></sdf>"
    )
    with pytest.warns(ScenarioWarning) as heard:
        scenario = load_scenario(_yaml(tmp_path, "w.world"))
    (line,) = [str(w.message) for w in heard]
    assert "read past 1 light" in line
    assert "Fuel's 'Sun', 'ground plane' not downloaded: mfi_drake's stand-in" in line
    assert scenario.ground.height == -1.0
    (wall,) = scenario.obstacles
    assert wall.position == [6.0, 0.0, 1.5]
