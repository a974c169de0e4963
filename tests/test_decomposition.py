"""Meshes of any shape (`!Mesh`): a non-convex mesh flies as the convex
pieces CoACD decomposes it into, cached on disk; `!Convex` of a non-convex
mesh warns; a mesh that cannot be decomposed is one line."""

import os

import numpy as np
import pytest

from mfi_drake.app.cli import main
from mfi_drake.config import scenario as sc
from mfi_drake.flight.simulation import simulate
from mfi_drake.world import decomposition
from mfi_drake.world.meshes import cells_mesh, enclosed_volume, write_obj
from mfi_drake.world.obstacles import obstacle_distances
from mfi_drake.world.shapes import shape_mesh
from mfi_drake.world.validation import ScenarioWarning, load_scenario

SCALE = 2.0
# A U of 0.5 m cells, scaled by 2: 5 × 4 m, 6 m tall, arms 1 m thick, its
# notch 3 × 3 m (x in [1, 4], y in [1, 4]) open towards +y.
U_CELLS = np.zeros((5, 4, 1), bool)
U_CELLS[0] = U_CELLS[4] = True
U_CELLS[:, 0] = True
NOTCH = [2.5, 2.5, 3.0]  # m, its centre: 1.5 m from each arm and the base

HEAD = """\
name: u
start: [2.5, 9.0, 3.0]
goal: [2.5, 2.5, 3.0]
duration: 30.0
"""


@pytest.fixture
def u_obj(tmp_path, monkeypatch):
    """The U as an OBJ file in tmp_path, pieces cached in tmp_path too."""
    monkeypatch.setenv("MFI_DRAKE_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "u.obj"
    write_obj(str(path), *cells_mesh(U_CELLS, [0.5, 0.5, 3.0]))
    return path


def _scenario(tmp_path, shape: str, head: str = HEAD) -> str:
    path = tmp_path / "u.yaml"
    path.write_text(f"{head}obstacles:\n  - shape: {shape}\n")
    return str(path)


def test_the_u_flies_as_its_pieces_written_as_convex(tmp_path, u_obj):
    """Its pieces hold the U's volume and leave its notch free (closed
    forms); the `!Mesh` and its pieces written out as `!Convex` obstacles
    fly the same flight, bit for bit; the goal in the notch is reached."""
    mesh = load_scenario(_scenario(tmp_path, f"!Mesh {{file: u.obj, scale: {SCALE}}}"))
    pieces = mesh.obstacles
    assert len(pieces) >= 3
    assert pieces[0].name == "obstacles[0] (mesh 'u.obj') piece 0"
    volume = sum(enclosed_volume(*shape_mesh(mesh, o.shape)) for o in pieces)
    assert volume == pytest.approx(U_CELLS.sum() * 0.75 * SCALE**3, rel=0.01)
    (d,) = obstacle_distances(mesh, [NOTCH])
    assert d == pytest.approx(1.5, abs=0.01)
    written = "".join(
        f"  - shape: !Convex {{vertices: {o.shape.vertices}}}\n"
        f"    position: {o.position}\n"
        for o in pieces
    )
    path = tmp_path / "pieces.yaml"
    path.write_text(f"{HEAD}obstacles:\n{written}")
    by_hand = load_scenario(str(path))
    a, b = simulate(mesh, until_settled=True), simulate(by_hand, until_settled=True)
    assert a.metrics["success"] and a.metrics["final_error"] < 0.1
    np.testing.assert_array_equal(a.times, b.times)
    for key in a.log:
        np.testing.assert_array_equal(a.log[key], b.log[key], err_msg=key)


def test_convex_of_the_u_refuses_the_notch_and_warns_one_line(tmp_path, u_obj, capsys):
    """`!Convex` flies the hull, which fills the notch: the goal there is
    refused, and the hull (15 m³ to the U's 8.25, unscaled) named in one
    warning line that says how to fly the real shape."""
    path = _scenario(tmp_path, f"!Convex {{file: u.obj, scale: {SCALE}}}")
    with (
        pytest.warns(ScenarioWarning, match="not convex"),
        pytest.raises(sc.ScenarioError, match="goal .* from an obstacle"),
    ):
        load_scenario(path)
    outside = HEAD.replace("goal: [2.5, 2.5, 3.0]", "goal: [2.5, 7.0, 3.0]")
    outside = outside.replace("duration: 30.0", "duration: 0.5")
    path = _scenario(tmp_path, f"!Convex {{file: u.obj, scale: {SCALE}}}", outside)
    # Flown (0.5 s: not reached, exit 1), not refused (2).
    assert main(["run", path, "--out", str(tmp_path / "out")]) == 1
    warnings = [
        line for line in capsys.readouterr().err.splitlines() if "warning" in line
    ]
    assert warnings == [
        f"mfi-drake: warning: {path}: obstacles[0]: shape.file = 'u.obj': not "
        "convex (its hull holds 1.82 times its volume), so !Convex flies the "
        "hull; !Mesh {file: u.obj} flies its shape"
    ]


def test_pieces_are_cached_by_content(u_obj, monkeypatch):
    """A second decomposition of the same mesh reads the cache (CoACD is not
    called again); another mesh is decomposed anew."""
    vertices, triangles = cells_mesh(U_CELLS, [0.5, 0.5, 3.0])
    first = decomposition.convex_pieces(vertices, triangles)
    (cached,) = os.listdir(decomposition.cache_dir())
    assert cached.endswith(".npz") and not cached.startswith(".tmp")

    def fail(*args, **kwargs):
        raise AssertionError("decomposed again")

    import coacd

    monkeypatch.setattr(coacd, "run_coacd", fail)
    again = decomposition.convex_pieces(vertices, triangles)
    assert len(again) == len(first)
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="decomposed again"):
        decomposition.convex_pieces(vertices * 2.0, triangles)


UNDECOMPOSABLE = [
    ("no faces", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n", "has no triangles"),
    (
        "no area",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
        "has no surface: every triangle has zero area",
    ),
    ("empty stl", None, "has no triangles"),
    ("missing", "", "no such file"),
]


@pytest.mark.parametrize(
    "label, text, needle", UNDECOMPOSABLE, ids=[u[0] for u in UNDECOMPOSABLE]
)
def test_a_mesh_that_cannot_be_decomposed_is_one_line(
    tmp_path, u_obj, capsys, label, text, needle
):
    name = "u.stl" if text is None else "bad.obj"
    if text is None:  # an STL file
        (tmp_path / name).write_text("solid u\nendsolid u\n")
    elif text:  # "": no file
        (tmp_path / name).write_text(text)
    path = _scenario(tmp_path, f"!Mesh {{file: {name}}}")
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{path}: obstacles[0]: shape.file = '{name}': {needle}" in err
    assert not out.exists()
