"""A world of many meshes as exporters write them (each corner repeated
for each face, as OBJ files with normals have it): decomposed over the
cores at once, a convex mesh as its hull, one piece, without CoACD; a
concave L as CoACD's pieces; an open plane as a slab. The oracles: each
box's piece against the same box written as `!Box` (closest distances
from probe points, SceneGraph both ways), the L's pieces against its
volume in closed form, the plane's slab against its corners."""

import numpy as np
import pytest

from mfi_drake.config import scenario as sc
from mfi_drake.world import decomposition
from mfi_drake.world.meshes import enclosed_volume
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.shapes import shape_mesh
from mfi_drake.world.surfaces import THICKNESS
from mfi_drake.world.validation import ScenarioWarning, load_scenario

HEAD = """\
name: many
start: [-3.0, 0.0, 1.0]
goal: [-3.0, 4.0, 1.0]
duration: 10.0
"""
BOXES = 18  # boxes of 0.4 × 0.6 × 0.8 m, in a row along x
BOX = np.array([0.4, 0.6, 0.8])
L_VOLUME = 3.0  # m³: the L below, three 1 m cells


def _faceted_box(size) -> str:
    """A box's OBJ text, corner at the origin, its 8 corners written once a
    face (24 vertices), as an exporter with normals writes them."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    faces = [
        [0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1],
        [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3],
    ]  # fmt: skip
    lines, k = [], 1
    for face in faces:
        lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in corners[face] * size]
        lines += [f"f {k} {k + 1} {k + 2}", f"f {k} {k + 2} {k + 3}"]
        k += 4
    return "\n".join(lines) + "\n"


def _l_shape() -> str:
    """A closed L of three 1 m cells (x, z): (0, 0), (1, 0), (0, 1)."""
    from mfi_drake.world.meshes import cells_mesh

    cells = np.zeros((2, 1, 2), bool)
    cells[0, 0, 0] = cells[1, 0, 0] = cells[0, 0, 1] = True
    vertices, triangles = cells_mesh(cells, [1.0, 1.0, 1.0])
    lines = [f"v {x:g} {y:g} {z:g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    return "\n".join(lines) + "\n"


def _model(name: str, mesh: str, x: float, y: float) -> str:
    return f"""
    <model name="{name}"><static>true</static><pose>{x} {y} 0 0 0 0</pose>
      <link name="link"><collision name="c" concave="yes"><geometry>
        <mesh><uri>{mesh}</uri></mesh></geometry></collision></link>
    </model>"""


@pytest.fixture
def world(tmp_path, monkeypatch):
    """The world: 18 boxes, an L and an open 2 × 2 m plane (an OBJ of two
    triangles), 20 meshes; its pieces cached in tmp_path."""
    monkeypatch.setenv("MFI_DRAKE_CACHE", str(tmp_path / "cache"))
    (tmp_path / "box.obj").write_text(_faceted_box(BOX))
    (tmp_path / "l.obj").write_text(_l_shape())
    (tmp_path / "plane.obj").write_text(
        "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3\nf 1 3 4\n"
    )
    models = [_model(f"box{k}", "box.obj", 1.0 * k, 0.0) for k in range(BOXES)]
    models += [_model("l", "l.obj", 0.0, 3.0), _model("plane", "plane.obj", 4, 3)]
    text = f'<sdf version="1.9"><world name="w">{"".join(models)}</world></sdf>'
    (tmp_path / "many.sdf").write_text(text)
    (tmp_path / "s.yaml").write_text(f"{HEAD}world: many.sdf\n")
    return tmp_path


def test_many_meshes_fly_as_hulls_pieces_and_slabs(world, monkeypatch):
    """Each faceted box is one piece, its hull, and flies as the `!Box`
    written by hand; only the L and the plane are decomposed (the cache
    holds their two entries: the boxes' hull needs none); the L's pieces
    hold its volume; the plane is one slab over its corners."""
    import os

    with pytest.warns(ScenarioWarning, match="concave= on <collision> \\(20×\\)"):
        scenario = load_scenario(str(world / "s.yaml"))
    named = {}
    for o in scenario.obstacles:
        named.setdefault(o.name.split("'")[3], []).append(o)
    assert sorted(named) == sorted([*(f"box{k}" for k in range(BOXES)), "l", "plane"])
    assert all(len(named[f"box{k}"]) == 1 for k in range(BOXES))
    assert len(named["l"]) >= 2
    assert len(os.listdir(world / "cache")) == 2
    l_volume = sum(enclosed_volume(*shape_mesh(scenario, o.shape)) for o in named["l"])
    assert l_volume == pytest.approx(L_VOLUME, rel=0.02)
    (slab,) = named["plane"]
    corners = np.asarray(slab.shape.vertices)
    assert np.ptp(corners, axis=0) == pytest.approx([2.0, 2.0, THICKNESS])
    boxes = [
        sc.Obstacle(
            shape=sc.Box(size=BOX.tolist()),
            position=(BOX / 2 + [1.0 * k, 0, 0]).tolist(),
        )
        for k in range(BOXES)
    ]
    by_hand = sc.Scenario(
        name="h", start=[-3, 0, 1], goal=[-3, 4, 1], duration=1.0, obstacles=boxes
    )
    loaded = sc.Scenario(
        name="l",
        start=[-3, 0, 1],
        goal=[-3, 4, 1],
        duration=1.0,
        obstacles=[o for k in range(BOXES) for o in named[f"box{k}"]],
    )
    probes = np.random.default_rng(1).uniform(
        [-1, -1, -0.5], [BOXES, 1.6, 1.5], (200, 3)
    )
    np.testing.assert_allclose(
        obstacle_distances(loaded, probes),
        obstacle_distances(by_hand, probes),
        atol=1e-6,
    )


def test_a_convex_mesh_wound_any_way_is_its_hull(tmp_path, monkeypatch):
    """A tessellated cylinder, its triangles wound either way, is one
    piece whose corners are its own, scaled, and nothing is cached."""
    monkeypatch.setenv("MFI_DRAKE_CACHE", str(tmp_path / "cache"))
    angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ring = np.c_[np.cos(angles), np.sin(angles)]
    vertices = np.vstack([np.c_[ring, np.zeros(24)], np.c_[ring, np.ones(24)]])
    triangles = [[i, (i + 1) % 24, 24 + (i + 1) % 24] for i in range(24)]
    triangles += [[i, 24 + (i + 1) % 24, 24 + i] for i in range(24)]
    triangles += [[0, (i + 1) % 24, i] for i in range(1, 23)]
    triangles += [[24, 24 + i, 24 + (i + 1) % 24] for i in range(1, 23)]
    (piece,) = decomposition.mesh_pieces(vertices, np.array(triangles), 2.0)
    np.testing.assert_allclose(
        np.sort(np.round(piece, 9), axis=0), np.sort(np.round(vertices * 2, 9), axis=0)
    )
    assert not (tmp_path / "cache").exists()


def test_a_fine_curved_shell_flies_as_a_bounded_count_of_pieces(tmp_path, monkeypatch):
    """A half-cylinder shell (radius 1 m, 2 m long) of 1,600 triangles, open,
    whose slabs would be hundreds: MAX_SLABS pieces that hold every vertex
    of it (distance ≤ 0) and leave its axis and the points 0.15 m off its
    surface free (against the shell's closed form: r = 1)."""
    monkeypatch.setenv("MFI_DRAKE_CACHE", str(tmp_path))
    angles = np.linspace(0.0, np.pi, 41)
    lengths = np.linspace(0.0, 2.0, 21)
    grid = np.array([[np.cos(a), y, np.sin(a)] for y in lengths for a in angles])
    n = len(angles)
    triangles = [
        t
        for j in range(len(lengths) - 1)
        for i in range(n - 1)
        for t in (
            [j * n + i, j * n + i + 1, (j + 1) * n + i + 1],
            [j * n + i, (j + 1) * n + i + 1, (j + 1) * n + i],
        )
    ]
    pieces = decomposition.mesh_pieces(grid, np.array(triangles), 1.0)
    assert len(pieces) == decomposition.MAX_SLABS
    scenario = sc.Scenario(
        name="shell",
        start=[0, -3, 0.5],
        goal=[0, 5, 0.5],
        duration=1.0,
        obstacles=[sc.Obstacle(shape=sc.Convex(vertices=p.tolist())) for p in pieces],
    )
    assert max(obstacle_distances(scenario, grid)) <= 1e-6
    rng = np.random.default_rng(5)
    a, y = rng.uniform(0.05, np.pi - 0.05, 100), rng.uniform(0.1, 1.9, 100)
    for r in (0.85, 1.15):
        off = np.c_[r * np.cos(a), y, r * np.sin(a)]
        assert min(obstacle_distances(scenario, off)) > 0.0
    assert (
        min(obstacle_distances(scenario, np.c_[np.zeros(20), y[:20], np.zeros(20)]))
        > 0.5
    )
