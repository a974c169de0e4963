"""Triangle meshes of the scenario's obstacle shapes, for drawing and OBJ I/O.

Drake does the geometry queries; these meshes only draw the obstacles in
matplotlib and read or write the Wavefront OBJ files of convex obstacles.
`shapes.SHAPES` says which mesh each shape kind uses.
"""

import os

import numpy as np

from mfi_drake.files import write_text


def read_obj(path: str) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N, 3), triangles (M, 3) of 0-based indices) of an OBJ file.

    Polygons are fanned into triangles. Raises ValueError if unreadable.
    """
    vertices, faces = [], []
    try:
        with open(path) as f:
            for line in f:
                parts = line.split()
                if not parts:
                    continue
                if parts[0] == "v":
                    vertices.append([float(x) for x in parts[1:4]])
                elif parts[0] == "f":
                    idx = [int(p.split("/")[0]) for p in parts[1:]]
                    idx = [i - 1 if i > 0 else len(vertices) + i for i in idx]
                    faces += [
                        [idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)
                    ]
    except (OSError, ValueError, IndexError) as e:
        raise ValueError(f"not a readable OBJ file ({e})") from None
    if not vertices:
        raise ValueError("has no vertices")
    return np.array(vertices), np.array(faces, dtype=int).reshape(-1, 3)


def enclosed_volume(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """The volume [m³] a closed mesh of outward-facing triangles encloses
    (the divergence theorem: a sum of signed tetrahedra)."""
    a, b, c = (np.asarray(vertices)[triangles[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def write_obj(path: str, vertices: np.ndarray, triangles: np.ndarray) -> None:
    """Writes an OBJ file atomically (temporary name, then rename)."""
    lines = [f"v {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n" for v in vertices]
    lines += [f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n" for t in triangles]
    write_text(path, "".join(lines))


def _grid_surface(fn, nu: int = 16, nv: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """A closed surface from fn(u in [0, 2π), v in [0, 1]) -> point."""
    us = np.linspace(0.0, 2.0 * np.pi, nu, endpoint=False)
    vs = np.linspace(0.0, 1.0, nv)
    verts = np.array([fn(u, v) for v in vs for u in us])
    tris = []
    for j in range(nv - 1):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            c, d = a + nu, b + nu
            tris += [[a, b, d], [a, d, c]]
    return verts, np.array(tris)


def box_mesh(size) -> tuple[np.ndarray, np.ndarray]:
    """A box of edge lengths `size`, centred on the origin."""
    h = np.asarray(size) / 2.0
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    quads = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ]
    tris = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return corners * h, np.array(tris)


def ellipsoid_mesh(radii) -> tuple[np.ndarray, np.ndarray]:
    """An ellipsoid of semi-axes `radii` (a sphere when they are equal)."""
    radii = np.asarray(radii, float)
    return _grid_surface(
        lambda u, v: (
            radii
            * [
                np.sin(np.pi * v) * np.cos(u),
                np.sin(np.pi * v) * np.sin(u),
                -np.cos(np.pi * v),
            ]
        )
    )


def cylinder_mesh(radius: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """A cylinder along z, closed by its two discs."""
    half = length / 2.0
    return _grid_surface(
        lambda u, v: [
            radius * np.cos(u) * min(1, 3 * v, 3 - 3 * v) if 0 < v < 1 else 0.0,
            radius * np.sin(u) * min(1, 3 * v, 3 - 3 * v) if 0 < v < 1 else 0.0,
            -half if v < 0.5 else half,
        ],
        nv=4,
    )


def capsule_mesh(radius: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """A capsule along z: a cylinder of `length` capped by hemispheres."""
    half = length / 2.0

    def capsule(u, v):
        a = np.pi * v  # polar angle from the bottom pole
        z = -radius * np.cos(a) + (half if v >= 0.5 else -half)
        return [radius * np.sin(a) * np.cos(u), radius * np.sin(a) * np.sin(u), z]

    return _grid_surface(capsule, nv=12)


def geodesic_sphere(subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Unit geodesic sphere (a subdivided icosahedron): a convex polytope."""
    t = (1.0 + 5.0**0.5) / 2.0
    verts = [
        [-1, t, 0],
        [1, t, 0],
        [-1, -t, 0],
        [1, -t, 0],
        [0, -1, t],
        [0, 1, t],
        [0, -1, -t],
        [0, 1, -t],
        [t, 0, -1],
        [t, 0, 1],
        [-t, 0, -1],
        [-t, 0, 1],
    ]
    verts = [list(np.asarray(v) / np.linalg.norm(v)) for v in verts]
    tris = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ]
    for _ in range(subdivisions):
        midpoint, new_tris = {}, []

        def mid(a, b, midpoint=midpoint):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                m = np.asarray(verts[a]) + np.asarray(verts[b])
                verts.append(list(m / np.linalg.norm(m)))
                midpoint[key] = len(verts) - 1
            return midpoint[key]

        for a, b, c in tris:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new_tris += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        tris = new_tris
    return np.array(verts), np.array(tris)


def prism(polygon: np.ndarray, height: float) -> tuple[np.ndarray, np.ndarray]:
    """A right prism over a convex counter-clockwise polygon (K, 2), z ∈ ±h/2."""
    k = len(polygon)
    bottom = np.column_stack([polygon, np.full(k, -height / 2)])
    top = np.column_stack([polygon, np.full(k, height / 2)])
    tris = [[0, i + 1, i] for i in range(1, k - 1)]  # bottom, facing −z
    tris += [[k, k + i, k + i + 1] for i in range(1, k - 1)]  # top, facing +z
    for i in range(k):
        j = (i + 1) % k
        tris += [[i, j, k + j], [i, k + j, k + i]]
    return np.vstack([bottom, top]), np.array(tris)


def cells_mesh(cells: np.ndarray, size) -> tuple[np.ndarray, np.ndarray]:
    """The closed surface of a union of grid cells: `cells` (nx, ny, nz) of
    booleans, each cell `size` (3,) m, the grid's corner at the origin; each
    face between a filled cell and an empty one (or the outside) is two
    triangles facing out. A non-convex solid (a U, an L, a building with a
    door) as one watertight mesh."""
    filled = np.pad(np.asarray(cells, bool), 1)
    index: dict[tuple, int] = {}
    triangles = []

    def corner(point) -> int:
        return index.setdefault(tuple(point), len(index))

    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        step = np.eye(3, dtype=int)[axis]
        for sign in (1, -1):
            # Cells whose neighbour along `sign` × axis is empty.
            beside = np.roll(filled, -sign, axis=axis)
            for cell in np.argwhere(filled & ~beside):
                base = cell - 1 + (step if sign > 0 else 0)
                quad = [base, base + np.eye(3, dtype=int)[u]]
                quad += [
                    quad[1] + np.eye(3, dtype=int)[v],
                    base + np.eye(3, dtype=int)[v],
                ]
                a, b, c, d = (corner(q) for q in quad)
                # Counter-clockwise seen from outside: (u, v, axis) is right-handed.
                tris = [[a, b, c], [a, c, d]] if sign > 0 else [[a, c, b], [a, d, c]]
                triangles += tris
    vertices = np.array(list(index), dtype=float) * np.asarray(size, float)
    return vertices, np.array(triangles, dtype=int)


def write_scenario_meshes(directory: str) -> list[str]:
    """Regenerates the convex meshes the shipped scenarios use."""
    os.makedirs(directory, exist_ok=True)
    canopy = os.path.join(directory, "canopy.obj")
    vertices, tris = geodesic_sphere(1)
    write_obj(canopy, vertices * [1.3, 1.3, 1.0], tris)
    wedge = os.path.join(directory, "wedge.obj")
    # A 3 m tall prism whose sharp 39° edge points along −x.
    write_obj(wedge, *prism(np.array([[0.0, 0.0], [2.0, -0.7], [2.0, 0.7]]), 3.0))
    building = os.path.join(directory, "building.obj")
    write_obj(building, *building_mesh())
    return [canopy, wedge, building]


def building_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A 4 × 4 × 3 m hut, corner at the origin: 0.5 m walls and roof around
    a room, a door 1 m wide and 2 m tall in its wall at x = 0 (a non-convex
    mesh, flown as its convex pieces: `!Mesh`)."""
    cells = np.ones((8, 8, 6), bool)
    cells[1:-1, 1:-1, :-1] = False  # the room
    cells[0, 3:5, :4] = False  # the door
    return cells_mesh(cells, [0.5, 0.5, 0.5])


if __name__ == "__main__":
    import sys

    for path in write_scenario_meshes(
        sys.argv[1] if len(sys.argv) > 1 else "scenarios/meshes"
    ):
        print(f"wrote {path}")
