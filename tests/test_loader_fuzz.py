"""Input robustness of the mesh and cloud readers: random bytes and
mutations of this project's own mesh and cloud files (tests/data/meshes)
only ever give a mesh or cloud, or a ValueError of one line, never
another exception and never a crash (hypothesis, bounded in time). A
mesh that reads is also cut into pieces when it is open (slabs; a closed
one would run CoACD, whose cost is not this test's), which must give
finite pieces or the one-line error. The counts of each outcome are
printed (`-s`) for the docs."""

import collections
import os
import resource
import tempfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mfi_drake.world.mesh_files import MESH_SUFFIXES, read_mesh
from mfi_drake.world.point_clouds import read_cloud
from mfi_drake.world.surfaces import closed, surface_slabs

from .conftest import ROOT

DATA = os.path.join(ROOT, "tests", "data", "meshes")
MESHES = sorted(f for f in os.listdir(DATA) if f.endswith(MESH_SUFFIXES))
CLOUDS = ["organized.pcd", "survey.las"]
FUZZ = settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
OUTCOMES: collections.Counter = collections.Counter()
SPECIAL = [
    b"nan",
    b"inf",
    b"-1",
    b"1e308",
    b"0",
    b"99999999999",
    b"\x00" * 4,
    b"\xff" * 8,
]


@pytest.fixture(scope="module")
def workdir():
    with tempfile.TemporaryDirectory() as d:
        yield d
    print("\nloader fuzz outcomes:", dict(sorted(OUTCOMES.items())))


@st.composite
def mutated(draw, names):
    """One of `names` with 1–4 byte-level mutations: flips, deletions,
    insertions (random or special tokens), a truncation, a repeated span."""
    name = draw(st.sampled_from(names))
    with open(os.path.join(DATA, name), "rb") as f:
        data = bytearray(f.read())
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, max(len(data) - 1, 0)))
        kind = draw(st.sampled_from(["flip", "delete", "insert", "truncate", "repeat"]))
        if kind == "flip" and data:
            data[i] ^= 1 << draw(st.integers(0, 7))
        elif kind == "delete":
            del data[i : i + draw(st.integers(1, 64))]
        elif kind == "insert":
            data[i:i] = draw(
                st.one_of(st.sampled_from(SPECIAL), st.binary(max_size=16))
            )
        elif kind == "truncate":
            del data[i:]
        else:
            data[i:i] = data[i : i + draw(st.integers(1, 256))]
    return name, bytes(data)


def _write(directory: str, name: str, data: bytes) -> str:
    path = os.path.join(directory, name)
    with open(path, "wb") as f:
        f.write(data)
    return path


def _mesh_or_one_line(path: str) -> None:
    try:
        vertices, triangles = read_mesh(path)
        if not closed(triangles):
            for piece in surface_slabs(vertices, triangles):
                assert np.isfinite(piece).all()
            OUTCOMES["mesh: slabs"] += 1
        else:
            OUTCOMES["mesh: closed"] += 1
    except ValueError as e:
        assert str(e) and "\n" not in str(e), str(e)
        OUTCOMES["mesh: one-line error"] += 1


def _cloud_or_one_line(path: str) -> None:
    try:
        points, dropped = read_cloud(path)
        assert np.isfinite(points).all() and len(points) and dropped >= 0
        OUTCOMES["cloud: read"] += 1
    except ValueError as e:
        assert str(e) and "\n" not in str(e), str(e)
        OUTCOMES["cloud: one-line error"] += 1


@FUZZ
@given(mutated(MESHES))
def test_mutated_meshes_read_or_fail_in_one_line(workdir, case):
    name, data = case
    _mesh_or_one_line(_write(workdir, name, data))


@FUZZ
@given(st.sampled_from(MESH_SUFFIXES), st.binary(max_size=2048))
def test_random_bytes_as_a_mesh_fail_in_one_line(workdir, suffix, data):
    _mesh_or_one_line(_write(workdir, "random" + suffix, data))


@FUZZ
@given(mutated(CLOUDS))
def test_mutated_clouds_read_or_fail_in_one_line(workdir, case):
    name, data = case
    _cloud_or_one_line(_write(workdir, name, data))


@FUZZ
@given(st.sampled_from([".pcd", ".ply", ".las", ".laz"]), st.binary(max_size=2048))
def test_random_bytes_as_a_cloud_fail_in_one_line(workdir, suffix, data):
    _cloud_or_one_line(_write(workdir, "random" + suffix, data))


def test_a_chunk_longer_than_its_file_is_one_line_not_the_machines_memory(workdir):
    """A GLB whose JSON chunk declares ~4 GB: the reader's memory is capped
    by the file's size (`bounded_memory`), so the read fails in one line.
    The fuzz found such a file, whose reading grew past 20 GB and was
    killed by the kernel, taking the test run with it."""
    with open(os.path.join(DATA, "box.glb"), "rb") as f:
        data = bytearray(f.read())
    assert data[16:20] == b"JSON"  # the first chunk's type; its length before
    data[12:16] = (0xFFFFFFF0).to_bytes(4, "little")
    before = resource.getrlimit(resource.RLIMIT_AS)
    with pytest.raises(ValueError, match="declares more data than the file holds"):
        read_mesh(_write(workdir, "long_chunk.glb", bytes(data)))
    assert resource.getrlimit(resource.RLIMIT_AS) == before  # the cap is lifted
