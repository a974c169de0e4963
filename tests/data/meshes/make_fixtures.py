"""Writes this folder's small mesh and cloud files, each in its format's own
convention, all of one scene so a test can compare them with primitives:

- box_*: a box of 1 × 2 × 0.5 m (x, y, z in Drake's z-up frame), one corner
  at the origin, as a binary and an ASCII STL, a PLY, a glTF and a GLB
  (y-up, as glTF is by spec: Drake's (x, y, z) is glTF's (x, z, −y)), a
  COLLADA file in centimetres (<unit meter="0.01">, Z_UP), a Y_UP one, a
  textured one whose image (box_textured.png) was cut off halfway and one
  whose image names no file;
- wall_open.ply: two single-sided walls, 4 × 3 m with a door 1 m wide and
  2 m tall at x ∈ [1.5, 2.5] in the plane y = 0, and 3 × 3 m in the plane
  x = 4, as 0.5 m grid squares: an open, flat mesh;
- organized.pcd: an organized cloud (32 × 24, binary_compressed) of a wall
  in the plane x = 3, NaN where a pixel had no return (every third column
  from 4 on and the bottom two rows), as a depth camera driver writes.

    python tests/data/meshes/make_fixtures.py
"""

import base64
import json
import os
import re
import struct
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SIZE = np.array([1.0, 2.0, 0.5])


def box() -> tuple[np.ndarray, np.ndarray]:
    """The box's corners and its 12 outward-facing triangles."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4]]
    quads.append([1, 5, 7, 3])
    tris = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return corners * SIZE, np.array(tris)


def to_y_up(vertices: np.ndarray) -> np.ndarray:
    """Drake's z-up (x, y, z) as a y-up file holds it: (x, z, −y)."""
    return np.column_stack([vertices[:, 0], vertices[:, 2], -vertices[:, 1]])


def write_stl(path: str, vertices, tris, binary: bool) -> None:
    a, b, c = (vertices[tris[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    if binary:
        with open(path, "wb") as f:
            f.write(b"box made by make_fixtures.py".ljust(80, b" "))
            f.write(struct.pack("<I", len(tris)))
            for n, p, q, r in zip(normals, a, b, c, strict=True):
                f.write(struct.pack("<12fH", *n, *p, *q, *r, 0))
        return
    lines = ["solid box"]
    for n, *corners in zip(normals, a, b, c, strict=True):
        lines += [f"  facet normal {n[0]:g} {n[1]:g} {n[2]:g}", "    outer loop"]
        lines += [f"      vertex {p[0]:g} {p[1]:g} {p[2]:g}" for p in corners]
        lines += ["    endloop", "  endfacet"]
    with open(path, "w") as f:
        f.write("\n".join([*lines, "endsolid box", ""]))


def write_ply(path: str, vertices, tris) -> None:
    from plyfile import PlyData, PlyElement

    vertex = np.array([tuple(v) for v in vertices], [(k, "f4") for k in "xyz"])
    face = np.array([(list(t),) for t in tris], [("vertex_indices", "i4", (3,))])
    elements = [
        PlyElement.describe(vertex, "vertex"),
        PlyElement.describe(face, "face"),
    ]
    PlyData(elements, text=True).write(path)


def write_dae(path: str, vertices, tris, meter: float, up: str, texture=None) -> None:
    """A COLLADA box; with `texture` (a file name beside it) its faces carry
    texture coordinates and a material that maps that image, as its colour
    and its bump map."""
    floats = " ".join(f"{x:g}" for x in vertices.ravel())
    textured = texture is not None
    # Without texture coordinates a face lists its vertices; with them each
    # corner is (vertex, uv), the uv cycling through the image's four corners.
    indices = enumerate(tris.ravel())
    corners = [f"{i} {k % 4}" if textured else str(i) for k, i in indices]
    uv_input = '<input semantic="TEXCOORD" source="#box-uv" offset="1" set="0"/>'
    uv_source = """<source id="box-uv">
          <float_array id="box-uv-array" count="8">0 0 1 0 1 1 0 1</float_array>
          <technique_common>
            <accessor source="#box-uv-array" count="4" stride="2">
              <param name="S" type="float"/>
              <param name="T" type="float"/>
            </accessor>
          </technique_common>
        </source>"""
    # An image of no file ("") is as Gazebo's tray parts ship theirs: its
    # <init_from> commented out.
    image = f"<init_from>{texture}</init_from>" if texture else "<!-- none -->"
    material = f"""<library_images>
    <image id="image">{image}</image>
  </library_images>
  <library_effects>
    <effect id="effect"><profile_COMMON>
      <newparam sid="surface">
        <surface type="2D"><init_from>image</init_from></surface>
      </newparam>
      <newparam sid="sampler"><sampler2D><source>surface</source></sampler2D></newparam>
      <technique sid="common"><lambert>
        <diffuse><texture texture="sampler" texcoord="uv"/></diffuse>
      </lambert>
      <extra><technique profile="FCOLLADA">
        <bump><texture texture="sampler" texcoord="uv"/></bump>
      </technique></extra></technique>
    </profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="material"><instance_effect url="#effect"/></material>
  </library_materials>"""
    bind = """<bind_material><technique_common>
          <instance_material symbol="paint" target="#material">
            <bind_vertex_input semantic="uv" input_semantic="TEXCOORD" input_set="0"/>
          </instance_material>
        </technique_common></bind_material>"""
    instance = '<instance_geometry url="#box"/>'
    if textured:
        instance = f'<instance_geometry url="#box">{bind}</instance_geometry>'
    text = f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <unit name="unit" meter="{meter}"/>
    <up_axis>{up}</up_axis>
  </asset>
  {material if textured else ""}
  <library_geometries>
    <geometry id="box" name="box">
      <mesh>
        <source id="box-positions">
          <float_array id="box-array" count="{vertices.size}">{floats}</float_array>
          <technique_common>
            <accessor source="#box-array" count="{len(vertices)}" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        {uv_source if textured else ""}
        <vertices id="box-vertices">
          <input semantic="POSITION" source="#box-positions"/>
        </vertices>
        <triangles count="{len(tris)}"{' material="paint"' if textured else ""}>
          <input semantic="VERTEX" source="#box-vertices" offset="0"/>
          {uv_input if textured else ""}
          <p>{" ".join(corners)}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="node" name="node">
        {instance}
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene>
    <instance_visual_scene url="#scene"/>
  </scene>
</COLLADA>
"""
    with open(path, "w") as f:
        f.write(re.sub(r"\n\s*\n", "\n", text))  # the untextured box's empty parts


def write_truncated_png(path: str) -> None:
    """A PNG of 32 × 32 noise cut off halfway through its pixels, as a
    download or a checkout interrupted leaves one: it opens, then fails
    when its pixels are read."""
    width = height = 32
    rows = (height, 3 * width + 1)
    pixels = np.random.default_rng(0).integers(0, 256, rows, np.uint8)
    pixels[:, 0] = 0  # each row's filter byte: none

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    whole = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
    whole += chunk(b"IDAT", zlib.compress(pixels.tobytes())) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(whole[: len(whole) // 2])


def gltf_parts(vertices, tris) -> tuple[dict, bytes]:
    """A glTF 2.0 document of one mesh and its binary buffer."""
    positions = np.asarray(vertices, "<f4").tobytes()
    indices = np.asarray(tris, "<u4").tobytes()
    document = {
        "asset": {"version": "2.0", "generator": "make_fixtures.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(positions) + len(indices)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices)},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": len(vertices),
                "type": "VEC3",
                "min": np.min(vertices, axis=0).tolist(),
                "max": np.max(vertices, axis=0).tolist(),
            },
            {
                "bufferView": 1,
                "componentType": 5125,
                "count": tris.size,
                "type": "SCALAR",
            },
        ],
    }
    return document, positions + indices


def write_gltf(path: str, vertices, tris) -> None:
    document, data = gltf_parts(vertices, tris)
    uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    document["buffers"][0]["uri"] = uri
    with open(path, "w") as f:
        json.dump(document, f, indent=1)


def write_glb(path: str, vertices, tris) -> None:
    document, data = gltf_parts(vertices, tris)
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
    chunks += struct.pack("<II", len(data), 0x004E4942) + data
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks)


def wall_grid() -> tuple[np.ndarray, np.ndarray]:
    """The two open walls of 0.5 m squares (see the module's docstring)."""
    vertices, tris = [], []

    def square(corners) -> None:
        base = len(vertices)
        vertices.extend(corners)
        tris.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])

    for i in range(8):
        for k in range(6):
            x, z = 0.5 * i, 0.5 * k
            if 1.5 <= x < 2.5 and z < 2.0:
                continue  # the door
            square([[x, 0, z], [x + 0.5, 0, z], [x + 0.5, 0, z + 0.5], [x, 0, z + 0.5]])
    for j in range(6):
        for k in range(6):
            y, z = 0.5 * j, 0.5 * k
            square([[4, y, z], [4, y + 0.5, z], [4, y + 0.5, z + 0.5], [4, y, z + 0.5]])
    return np.array(vertices, float), np.array(tris)


def write_organized_pcd(path: str) -> None:
    from pypcd4 import Encoding, PointCloud

    width, height = 32, 24
    u, v = np.meshgrid(np.arange(width), np.arange(height))
    points = np.stack(
        [np.full(u.shape, 3.0), -1.5 + u * 0.1, 0.2 + (height - 1 - v) * 0.1], axis=-1
    ).astype(np.float32)
    points[:, 4::3] = np.nan  # no return
    points[-2:, :] = np.nan
    cloud = PointCloud.from_xyz_points(points.reshape(-1, 3))
    cloud.metadata.width, cloud.metadata.height = width, height
    cloud.save(path, encoding=Encoding.BINARY_COMPRESSED)


def main() -> None:
    vertices, tris = box()
    out = lambda name: os.path.join(HERE, name)  # noqa: E731
    write_stl(out("box_binary.stl"), vertices, tris, binary=True)
    write_stl(out("box_ascii.stl"), vertices, tris, binary=False)
    write_ply(out("box.ply"), vertices, tris)
    write_dae(out("box_cm.dae"), vertices * 100.0, tris, 0.01, "Z_UP")
    write_dae(out("box_y_up.dae"), to_y_up(vertices), tris, 1.0, "Y_UP")
    write_dae(out("box_textured.dae"), vertices, tris, 1.0, "Z_UP", "box_textured.png")
    write_truncated_png(out("box_textured.png"))
    write_dae(out("box_imageless.dae"), vertices, tris, 1.0, "Z_UP", "")
    write_gltf(out("box.gltf"), to_y_up(vertices), tris)
    write_glb(out("box.glb"), to_y_up(vertices), tris)
    write_ply(out("wall_open.ply"), *wall_grid())
    write_organized_pcd(out("organized.pcd"))


if __name__ == "__main__":
    main()
