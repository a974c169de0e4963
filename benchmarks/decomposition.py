"""Convex decomposition libraries compared: CoACD and V-HACD (vhacdx, the
binding trimesh uses) on three non-convex meshes, for `!Mesh`.

    pip install vhacdx  # V-HACD: this benchmark's only use of it
    python benchmarks/decomposition.py [--samples 40000]

Meshes (m): a U (2.5 × 2 × 3, arms 0.5 thick, the notch 1.5 × 1.5), an
L-shaped building (6 × 6 × 4, wings 2 deep, the courtyard 4 × 4 in the
L's corner) and a torus ring (radii 1.5 and 0.4, 48 × 16 facets). For each
library at its default parameters and a pieces cap of 16 (`--max-pieces`):
pieces, wall time (best of 2), and fidelity by Monte Carlo over `--samples`
points in the mesh's box grown by 10 %:

- lost: the share of the mesh's volume no piece covers;
- extra: the volume the pieces cover outside the mesh, as a share of the
  mesh's (free space a vehicle may not fly through);
- reach: how far [m] the pieces reach into free space: the largest distance
  from the mesh's surface of a sample inside a piece but outside the mesh.

The inside test of the mesh is its winding number; of a piece, the half
spaces of the hull Drake computes.
"""

import argparse
import time

import numpy as np

from mfi_drake.config import scenario as sc
from mfi_drake.world.meshes import cells_mesh
from mfi_drake.world.shapes import drake_shape


def u_mesh():
    cells = np.zeros((5, 4, 1), bool)
    cells[0] = cells[4] = True
    cells[:, 0] = True
    return cells_mesh(cells, [0.5, 0.5, 3.0])


def l_mesh():
    cells = np.zeros((3, 3, 1), bool)
    cells[0] = True
    cells[:, 0] = True
    return cells_mesh(cells, [2.0, 2.0, 4.0])


def torus_mesh(big=1.5, small=0.4, nu=48, nv=16):
    us = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    vs = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    vertices = np.array(
        [
            [
                (big + small * np.cos(v)) * np.cos(u),
                (big + small * np.cos(v)) * np.sin(u),
                small * np.sin(v),
            ]
            for u in us
            for v in vs
        ]
    )
    tris = []
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = i * nv + (j + 1) % nv, ((i + 1) % nu) * nv + (j + 1) % nv
            tris += [[a, b, d], [a, d, c]]
    return vertices, np.array(tris)


def winding_inside(vertices, triangles, points, chunk=2000):
    """Whether each point is inside the closed mesh (winding number ≈ 1)."""
    out = []
    for k in range(0, len(points), chunk):
        p = points[k : k + chunk, None, :]
        a, b, c = (vertices[triangles[:, i]][None] - p for i in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum("pti,pti->pt", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("pti,pti->pt", a, b) * lc
            + np.einsum("pti,pti->pt", b, c) * la
            + np.einsum("pti,pti->pt", c, a) * lb
        )
        out.append(np.abs(np.arctan2(det, den).sum(axis=1) / (2 * np.pi)) > 0.5)
    return np.concatenate(out)


def hull_planes(points):
    """(normals, offsets) of the hull Drake computes of `points`."""
    convex = sc.Convex(vertices=np.asarray(points).tolist())
    hull = drake_shape(sc.Scenario(), convex).GetConvexHull()
    normals = np.array([hull.face_normal(f) for f in range(hull.num_faces())])
    offsets = np.array(
        [
            normals[f] @ hull.vertex(hull.element(f).vertex(0))
            for f in range(hull.num_faces())
        ]
    )
    return normals, offsets


def surface_samples(vertices, triangles, n, rng):
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(triangles), n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    return (
        (1 - s)[:, None] * a[pick]
        + (s * (1 - r2))[:, None] * b[pick]
        + (s * r2)[:, None] * c[pick]
    )


def coacd_pieces(vertices, triangles, max_pieces):
    import coacd

    coacd.set_log_level("error")
    mesh = coacd.Mesh(vertices, triangles)
    return [v for v, _ in coacd.run_coacd(mesh, max_convex_hull=max_pieces, seed=0)]


def vhacd_pieces(vertices, triangles, max_pieces):
    import vhacdx

    parts = vhacdx.compute_vhacd(
        vertices, triangles.astype(np.uint32), maxConvexHulls=max_pieces
    )
    return [v for v, _ in parts]


def fidelity(vertices, triangles, pieces, samples, rng):
    low, high = vertices.min(0), vertices.max(0)
    pad = 0.1 * (high - low)
    points = rng.uniform(low - pad, high + pad, (samples, 3))
    box = np.prod(high - low + 2 * pad)
    in_mesh = winding_inside(vertices, triangles, points)
    in_piece = np.zeros(samples, bool)
    for piece in pieces:
        if np.ptp(piece, axis=0).min() < 1e-9:  # flat: no volume to cover
            continue
        n, d = hull_planes(piece)
        in_piece |= (points @ n.T <= d + 1e-9).all(axis=1)
    mesh_volume = in_mesh.mean() * box
    lost = (in_mesh & ~in_piece).mean() * box / mesh_volume
    extra = (~in_mesh & in_piece).mean() * box / mesh_volume
    outside = points[~in_mesh & in_piece]
    reach = 0.0
    if len(outside):
        surface = surface_samples(vertices, triangles, 20000, rng)
        reach = max(
            float(
                np.min(np.linalg.norm(surface[None] - p[:, None], axis=2), axis=1).max()
            )
            for p in np.array_split(outside, max(1, len(outside) // 500))
        )
    return lost, extra, reach


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=40000)
    parser.add_argument("--max-pieces", type=int, default=16)
    args = parser.parse_args()
    meshes = {"U": u_mesh(), "L building": l_mesh(), "torus ring": torus_mesh()}
    libraries = {"CoACD": coacd_pieces, "V-HACD": vhacd_pieces}
    print("| mesh | library | pieces | time [s] | lost | extra | reach [m] |")
    print("|---|---|---|---|---|---|---|")
    for name, (vertices, triangles) in meshes.items():
        for library, decompose in libraries.items():
            times = []
            for _ in range(2):
                start = time.perf_counter()
                pieces = decompose(vertices, triangles, args.max_pieces)
                times.append(time.perf_counter() - start)
            rng = np.random.default_rng(0)
            lost, extra, reach = fidelity(
                vertices, triangles, pieces, args.samples, rng
            )
            print(
                f"| {name} | {library} | {len(pieces)} | {min(times):.2f} | "
                f"{lost:.1%} | {extra:.1%} | {reach:.3f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
