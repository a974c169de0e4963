"""MuJoCo scenes as MuJoCo Menagerie writes them: a floor plane among
hundreds of geoms is the scenario's ground, never a half space in Drake's
SceneGraph (which crashed with many geometries: Drake #19263); visual
geoms (contype and conaffinity 0, from a default class) and the mesh
assets only they use are read past, even when the mesh file is missing;
includes are inlined. The oracles: the boxes as written (their MJCF half
sizes doubled by hand), the ground's height as written, a clean exit of
separate processes."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mfi_drake.config import scenario as sc
from mfi_drake.config.worlds import ScenarioWarning
from mfi_drake.world.sdformat import prepare
from mfi_drake.world.validation import load_scenario

from .conftest import ROOT

HEAD = """\
name: mjcf
start: [-2.0, -2.0, 1.0]
goal: [-2.0, 2.0, 1.0]
duration: 5.0
"""
BOXES = 300


def _boxes(seed: int = 4) -> np.ndarray:
    """(BOXES, 3) centres scattered over 40 × 30 × 3 m, away from x < 0."""
    return np.random.default_rng(seed).uniform([1, -15, 0.5], [41, 15, 3.5], (BOXES, 3))


@pytest.fixture
def floor_scene(tmp_path):
    """A floor plane at z = 0.25 (pos) and 300 boxes of 0.3 m (half size
    0.15), the boxes in an included file, as a Menagerie scene includes
    its robot."""
    geoms = "".join(
        f'<geom name="b{k}" type="box" size="0.15 0.15 0.15" pos="{x} {y} {z}"/>\n'
        for k, (x, y, z) in enumerate(_boxes())
    )
    (tmp_path / "boxes.xml").write_text(
        f'<mujoco model="boxes"><worldbody>{geoms}</worldbody></mujoco>'
    )
    (tmp_path / "scene.xml").write_text(
        textwrap.dedent("""\
        <mujoco model="floor">
          <include file="boxes.xml"/>
          <worldbody>
            <geom name="floor" type="plane" size="0 0 0.05" pos="0 0 0.25"/>
          </worldbody>
        </mujoco>
        """)
    )
    (tmp_path / "s.yaml").write_text(f"{HEAD}world: scene.xml\n")
    return tmp_path


def test_a_floor_among_300_boxes_is_the_ground(floor_scene):
    """The plane never reaches Drake as a plane (a placeholder marked with
    its line stands for it); it is the ground at its height; the boxes are
    as written, from the included file."""
    prepared = prepare(str(floor_scene / "scene.xml"), [])
    assert 'type="plane"' not in prepared.texts[0]
    assert prepared.planes == [([0.0, 0.0, 1.0], f"{floor_scene / 'scene.xml'}:4")]
    scenario = load_scenario(str(floor_scene / "s.yaml"))
    assert scenario.ground == sc.Ground(height=0.25)
    assert len(scenario.obstacles) == BOXES
    assert all(o.shape == sc.Box(size=[0.3, 0.3, 0.3]) for o in scenario.obstacles)
    np.testing.assert_allclose(
        [o.position for o in scenario.obstacles], _boxes(), atol=1e-12
    )


def test_the_floor_scene_loads_in_fresh_processes(floor_scene):
    """Loaded in three processes of its own, each exits cleanly (the crash
    was intermittent: 8 in 10 runs with 150 boxes and a half space)."""
    code = (
        "import sys; from mfi_drake.world.validation import load_scenario; "
        "s = load_scenario(sys.argv[1]); print(len(s.obstacles), s.ground.height)"
    )
    env = {**os.environ, "PYTHONPATH": ROOT}
    for _ in range(3):
        done = subprocess.run(
            [sys.executable, "-W", "ignore", "-c", code, str(floor_scene / "s.yaml")],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr[-500:]
        assert done.stdout.split() == [str(BOXES), "0.25"]


def test_visual_geoms_and_their_missing_meshes_are_read_past(tmp_path):
    """A robot in Menagerie's manner: visual geoms of a default class
    (contype = conaffinity = 0) with STL meshes that are not there, one
    collision box; a tilted plane is a slab, not the ground."""
    (tmp_path / "robot.xml").write_text(
        textwrap.dedent("""\
        <mujoco model="robot">
          <default>
            <default class="visual">
              <geom type="mesh" contype="0" conaffinity="0" group="2"/>
            </default>
          </default>
          <asset>
            <mesh name="shell" file="assets/shell.stl"/>
            <mesh file="assets/arm.stl"/>
          </asset>
          <worldbody>
            <body name="base" pos="3 0 1" childclass="visual">
              <geom mesh="shell"/>
              <geom mesh="arm"/>
              <geom class="main" type="box" size="0.5 0.25 1" contype="1"/>
            </body>
            <geom type="plane" size="1 1 0.1" pos="0 5 0" euler="90 0 0"/>
          </worldbody>
        </mujoco>
        """)
    )
    (tmp_path / "s.yaml").write_text(f"{HEAD}world: robot.xml\n")
    with pytest.warns(ScenarioWarning, match="read past 2 visuals"):
        scenario = load_scenario(str(tmp_path / "s.yaml"))
    assert scenario.ground is None
    slab, box = sorted(scenario.obstacles, key=lambda o: -o.shape.size[0])
    assert box.shape == sc.Box(size=[1.0, 0.5, 2.0])
    np.testing.assert_allclose(box.position, [3, 0, 1], atol=1e-12)
    assert slab.shape == sc.Box(size=[1000.0, 1000.0, 10.0])
    # The plane through y = 5 faces -y (z turned by roll 90°): the slab
    # lies beyond it, its centre 5 m further along +y.
    np.testing.assert_allclose(slab.position, [0, 10, 0], atol=1e-9)


def _ascii_stl(path, vertices, triangles) -> None:
    facets = "".join(
        "facet normal 0 0 0\nouter loop\n"
        + "".join(f"vertex {x} {y} {z}\n" for x, y, z in vertices[list(t)])
        + "endloop\nendfacet\n"
        for t in triangles
    )
    path.write_text(f"solid s\n{facets}endsolid s\n")


def test_a_collision_mesh_flies_as_its_convex_hull_scaled_as_mujoco_reads_it(
    tmp_path,
):
    """MuJoCo collides with a mesh's convex hull. A tetrahedron STL (Drake's
    MJCF parser reads OBJ only) in `meshdir`, scaled by its own scale
    (1, 1, 3), which replaces its default class's (2, 2, 2), at its geom's
    pos (in its body's frame): the
    obstacle is the hull of those vertices, where the geom puts it; a
    point inside the hull (the tetrahedron's centroid) adds no vertex."""
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.2, 0.2]])
    (tmp_path / "meshes").mkdir()
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    _ascii_stl(tmp_path / "meshes" / "tetra.stl", tetra, faces)
    (tmp_path / "scene.xml").write_text(
        textwrap.dedent("""\
        <mujoco model="m">
          <compiler meshdir="meshes"/>
          <default><mesh scale="2 2 2"/></default>
          <asset><mesh file="tetra.stl" scale="1 1 3"/></asset>
          <worldbody>
            <body pos="4 1 0"><geom type="mesh" mesh="tetra" pos="0 0 0.5"/></body>
          </worldbody>
        </mujoco>
        """)
    )
    (tmp_path / "s.yaml").write_text(f"{HEAD}world: scene.xml\n")
    (hull,) = load_scenario(str(tmp_path / "s.yaml")).obstacles
    corners = np.asarray(hull.shape.vertices) + hull.position
    expected = tetra[:4] * [1, 1, 3] + [4, 1, 0.5]
    assert len(corners) == 4
    np.testing.assert_allclose(
        sorted(corners.tolist()), sorted(expected.tolist()), atol=1e-12
    )


def test_a_mesh_geom_naming_no_asset_is_one_line(tmp_path):
    (tmp_path / "scene.xml").write_text(
        '<mujoco><worldbody><geom type="mesh" mesh="gone"/></worldbody></mujoco>'
    )
    (tmp_path / "s.yaml").write_text(f"{HEAD}world: scene.xml\n")
    with pytest.raises(sc.ScenarioError, match="names no mesh asset .'gone'."):
        load_scenario(str(tmp_path / "s.yaml"))
