"""The one table of obstacle shape kinds: for each scenario shape, its Drake
shape (for SceneGraph), its triangle mesh (for drawing), the radius of a
ball about its frame origin that holds it, and how the random fields draw
one. Every piece of code that needs to know a shape's kind reads it here.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.common import MemoryFile
from pydrake.geometry import Box as DrakeBox
from pydrake.geometry import Capsule as DrakeCapsule
from pydrake.geometry import Convex as DrakeConvex
from pydrake.geometry import Cylinder as DrakeCylinder
from pydrake.geometry import Ellipsoid as DrakeEllipsoid
from pydrake.geometry import InMemoryMesh, MeshSource
from pydrake.geometry import Sphere as DrakeSphere

from mfi_drake.config import scenario as sc
from mfi_drake.world.meshes import (
    box_mesh,
    capsule_mesh,
    cylinder_mesh,
    ellipsoid_mesh,
    geodesic_sphere,
    prism,
    read_obj,
)

Mesh = tuple[np.ndarray, np.ndarray]  # vertices (N, 3), triangles (M, 3)


@dataclass(frozen=True)
class ShapeKind:
    name: str  # as the random fields and their tests call it
    drake: Callable[[object, str], object]  # (shape, mesh file) -> Drake shape
    mesh: Callable[[object, str], Mesh]  # (shape, mesh file) -> in its own frame
    radius: Callable[[object, str], float]  # (shape, mesh file) -> bounding radius
    sizes: tuple  # ranges [m] the random fields draw sizes from, uniformly
    random: Callable  # (rng, sizes) -> a random shape of this kind


def _random_convex(rng: np.random.Generator, sizes) -> sc.Convex:
    """A random convex polytope: a prism over 3–7 points on an ellipse taken in
    angular order (so the polygon is convex), or a stretched icosahedron;
    its vertices inline, to the micrometre (as the fields' OBJ files held
    them, so the fields are those they were)."""
    low, high = sizes
    if rng.random() < 0.5:
        k = int(rng.integers(3, 8))
        # One angle in each of k equal sectors: convex, and no slivers.
        angles = (np.arange(k) + rng.uniform(0.1, 0.9, k)) * (2 * np.pi / k)
        axes = rng.uniform(low, high, 2)
        polygon = np.column_stack([axes[0] * np.cos(angles), axes[1] * np.sin(angles)])
        mesh = prism(polygon, rng.uniform(2 * low, 2 * high))
    else:
        vertices, triangles = geodesic_sphere(0)
        mesh = vertices * rng.uniform(low, high, 3), triangles
    return sc.Convex(vertices=[[round(float(x), 6) for x in v] for v in mesh[0]])


def convex_points(shape: sc.Convex, mesh_file: str) -> np.ndarray:
    """(N, 3) points whose hull the shape is, unscaled: its inline vertices,
    else its file's."""
    if shape.vertices:
        return np.array(shape.vertices, dtype=float)
    return read_obj(mesh_file)[0]


def _drake_convex(shape: sc.Convex, mesh_file: str) -> DrakeConvex:
    """Drake's Convex of a file, or of inline vertices as an in-memory OBJ
    (Drake takes the hull of either's vertices): nothing read from disk."""
    if not shape.vertices:
        return DrakeConvex(mesh_file, shape.scale)
    text = "".join(
        f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in shape.vertices
    )
    memory = MemoryFile(text, ".obj", "inline convex vertices")
    return DrakeConvex(MeshSource(InMemoryMesh(mesh_file=memory)), shape.scale)


def _convex_mesh(shape: sc.Convex, mesh_file: str) -> Mesh:
    """The file's mesh, or the hull Drake computes of inline vertices (its
    polygons fanned into triangles)."""
    if not shape.vertices:
        vertices, triangles = read_obj(mesh_file)
        return vertices * shape.scale, triangles
    hull = _drake_convex(shape, mesh_file).GetConvexHull()
    vertices = np.array([hull.vertex(i) for i in range(hull.num_vertices())])
    triangles = []
    for f in range(hull.num_elements()):
        face = hull.element(f)
        corners = [face.vertex(k) for k in range(face.num_vertices())]
        triangles += [
            [corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1)
        ]
    return vertices, np.array(triangles, dtype=int).reshape(-1, 3)


def _uniform(rng, size, n=None):
    return [float(x) for x in rng.uniform(*size, n)] if n else float(rng.uniform(*size))


SHAPES: dict[type, ShapeKind] = {
    sc.Box: ShapeKind(
        "box",
        drake=lambda s, _: DrakeBox(*s.size),
        mesh=lambda s, _: box_mesh(s.size),
        radius=lambda s, _: 0.5 * float(np.linalg.norm(s.size)),
        sizes=(0.3, 1.5),  # each edge
        random=lambda rng, size: sc.Box(size=_uniform(rng, size, 3)),
    ),
    sc.Sphere: ShapeKind(
        "sphere",
        drake=lambda s, _: DrakeSphere(s.radius),
        mesh=lambda s, _: ellipsoid_mesh([s.radius] * 3),
        radius=lambda s, _: s.radius,
        sizes=(0.25, 0.75),  # radius
        random=lambda rng, size: sc.Sphere(radius=_uniform(rng, size)),
    ),
    sc.Cylinder: ShapeKind(
        "cylinder",
        drake=lambda s, _: DrakeCylinder(s.radius, s.length),
        mesh=lambda s, _: cylinder_mesh(s.radius, s.length),
        radius=lambda s, _: math.hypot(s.radius, 0.5 * s.length),
        sizes=((0.15, 0.5), (0.5, 2.0)),  # radius, length
        random=lambda rng, size: sc.Cylinder(*(_uniform(rng, r) for r in size)),
    ),
    sc.Capsule: ShapeKind(
        "capsule",
        drake=lambda s, _: DrakeCapsule(s.radius, s.length),
        mesh=lambda s, _: capsule_mesh(s.radius, s.length),
        radius=lambda s, _: s.radius + 0.5 * s.length,
        sizes=((0.15, 0.45), (0.3, 1.5)),  # radius, length of the straight part
        random=lambda rng, size: sc.Capsule(*(_uniform(rng, r) for r in size)),
    ),
    sc.Ellipsoid: ShapeKind(
        "ellipsoid",
        drake=lambda s, _: DrakeEllipsoid(*s.radii),
        mesh=lambda s, _: ellipsoid_mesh(s.radii),
        radius=lambda s, _: max(s.radii),
        sizes=(0.2, 0.8),  # each semi-axis
        random=lambda rng, size: sc.Ellipsoid(radii=_uniform(rng, size, 3)),
    ),
    sc.Convex: ShapeKind(
        "convex",
        drake=_drake_convex,
        mesh=_convex_mesh,
        radius=lambda s, path: (
            s.scale * float(np.max(np.linalg.norm(convex_points(s, path), axis=1)))
        ),
        sizes=(0.3, 0.8),  # polygon semi-axes / icosahedron radii
        random=_random_convex,
    ),
}


def shape_kind(shape) -> ShapeKind:
    """The table's entry of a scenario shape."""
    try:
        return SHAPES[type(shape)]
    except KeyError:
        raise TypeError(f"unknown shape {shape!r}") from None


def mesh_file(scenario: sc.Scenario, shape) -> str:
    """The mesh file a shape reads ("" for the primitives and inline vertices)."""
    if isinstance(shape, sc.Convex) and shape.file:
        return sc.mesh_path(scenario, shape)
    return ""


def drake_shape(scenario: sc.Scenario, shape):
    """The pydrake.geometry shape of a scenario shape."""
    return shape_kind(shape).drake(shape, mesh_file(scenario, shape))


def shape_mesh(scenario: sc.Scenario, shape) -> Mesh:
    """Vertices and triangles of `shape` in its own frame."""
    return shape_kind(shape).mesh(shape, mesh_file(scenario, shape))


def bounding_radius(scenario: sc.Scenario, shape) -> float:
    """Radius of a ball about the obstacle's frame origin holding the shape [m]."""
    return shape_kind(shape).radius(shape, mesh_file(scenario, shape))
