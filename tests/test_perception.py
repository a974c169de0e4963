"""The depth camera's perception steps (`maths.perception`), each against an
independent oracle: brute force, hand-built geometry, closed forms."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mfi_drake.maths.perception import (
    BLOCK,
    Frame,
    Groups,
    Intrinsics,
    Memory,
    Thinning,
    components,
    nearest_basins,
    remember,
    seen_again,
    surface_links,
    voxel_graph,
)

# An 80 × 60 camera at the world origin looking along world +z (R_CW = I).
CAMERA = Intrinsics(80, 60, 50.0, 50.0, 39.5, 29.5)


def rays(camera: Intrinsics = CAMERA) -> np.ndarray:
    """(3, height·width) pixel rays with z = 1, row-major (pinhole model)."""
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    x = (u.ravel() - camera.center_x) / camera.focal_x
    y = (v.ravel() - camera.center_y) / camera.focal_y
    return np.stack([x, y, np.ones_like(x)])


def thin(cloud: np.ndarray, camera: Intrinsics = CAMERA, centre=(0.0, 0.0, 0.0)):
    """The thinned frame of an organized cloud (its depth image is its z)."""
    thinning = Thinning(rays(camera), camera.width, camera.height, np.asarray(centre))
    depth = cloud[2].reshape(camera.height, camera.width)
    return thinning(cloud, depth)


def plane_cloud(normal, offset, camera: Intrinsics = CAMERA) -> np.ndarray:
    """The organized cloud of the plane n·X = offset: each ray ρ meets it at
    z = offset / (n·ρ); rays that miss it (z ≤ 0) have no return (inf)."""
    rho = rays(camera)
    z = offset / (np.asarray(normal) @ rho)
    z[~(z > 0)] = np.inf
    return rho * z


def test_thin_keeps_the_nearest_return_of_each_block():
    rng = np.random.default_rng(1)
    cloud = rays() * rng.uniform(1.0, 5.0, CAMERA.width * CAMERA.height)
    cloud[:, rng.random(cloud.shape[1]) < 0.3] = np.inf
    centre = np.array([0.1, -0.2, 0.05])
    frame = thin(cloud, centre=centre)
    cols = CAMERA.width // BLOCK
    image = cloud.reshape(3, CAMERA.height, CAMERA.width)
    expected = {}
    for r, c in itertools.product(range(CAMERA.height // BLOCK), range(cols)):
        block = image[:, r * BLOCK : (r + 1) * BLOCK, c * BLOCK : (c + 1) * BLOCK]
        points = block.reshape(3, -1).T
        points = points[np.all(np.isfinite(points), axis=1)]
        if len(points):
            d = np.linalg.norm(points - centre, axis=1)
            expected[r * cols + c] = points[np.argmin(d)]
    assert sorted(frame.blocks.tolist()) == sorted(expected)
    for block, point in zip(frame.blocks, frame.points, strict=True):
        np.testing.assert_array_equal(point, expected[block])


def test_thin_takes_partial_blocks_at_the_right_and_bottom_edges():
    camera = Intrinsics(7, 5, 5.0, 5.0, 3.0, 2.0)
    frame = thin(rays(camera) * 2.0, camera)
    assert frame.grid == (2, 2) and sorted(frame.blocks.tolist()) == [0, 1, 2, 3]


@pytest.mark.parametrize("grazing_deg", [90.0, 30.0, 5.0])
def test_a_plane_is_one_surface_however_obliquely_it_is_seen(grazing_deg):
    # A plane 0.5 m from the camera whose normal makes 90° − grazing with
    # the view axis: at 5° the samples are metres apart along it.
    a = np.radians(grazing_deg)
    normal = np.array([np.cos(a), 0.0, np.sin(a)])
    cloud = plane_cloud(normal, 0.5)
    frame = thin(cloud)
    graph = voxel_graph(frame.points, surface_links(frame))
    assert len(frame.points) > 50 and graph.count > 10
    (basin,) = nearest_basins(frame.points, graph, np.zeros(3), 3)
    # Its nearest sample is the nearest return of the whole image (beyond
    # 60° the plane's foot 0.5 n is out of view: the image's edge is then the
    # nearest seen, the edge of what was seen, not of the plane).
    nearest = np.linalg.norm(frame.points[graph.voxel_of == basin], axis=1).min()
    returns = cloud[:, np.isfinite(cloud[2])]
    assert nearest == np.linalg.norm(returns, axis=0).min()


def test_an_occluding_edge_is_not_one_surface():
    # A wall at z = 1 on the left half of the image in front of one at z = 3.
    cloud = plane_cloud([0.0, 0.0, 1.0], 3.0)
    left = rays()[0] < 0.0
    cloud[:, left] = rays()[:, left] * 1.0
    frame = thin(cloud)
    links = surface_links(frame)
    near = frame.points[:, 2] < 2.0
    assert near.any() and (~near).any() and len(links) > len(frame.points)
    assert np.all(near[links[:, 0]] == near[links[:, 1]])


def test_seen_again_clears_free_space_and_sightings_but_not_what_is_hidden():
    depth = np.full((CAMERA.height, CAMERA.width), 3.0)
    depth[:, :10] = np.inf  # no return within range
    depth[:, -10:] = 0.0  # closer than the minimum depth

    # Rays through the image centre, through columns u = 6 (no return) and
    # u = 73 (too close), and through u = 1, within BLOCK of the edge.
    def ray(u):
        return np.array([(u - CAMERA.center_x) / CAMERA.focal_x, 0.0, 1.0])

    centre = ray(CAMERA.center_x)
    points = np.array(
        [
            2.0 * centre,  # in front of the measured 3 m: free space
            3.05 * centre,  # the measured surface, seen again
            4.0 * centre,  # behind it: hidden, kept
            [0.0, 5.0, 1.0],  # outside the image: kept
            -2.0 * centre,  # behind the camera: kept
            5.0 * ray(6),  # no return: free up to max_range 6
            7.0 * ray(6),  # beyond max_range: kept
            0.5 * ray(73),  # a too-close pixel shows nothing: kept
            2.0 * ray(1),  # the edge of the image clears nothing: kept
        ]
    )
    cleared = seen_again(points, np.eye(3), np.zeros(3), CAMERA, depth, 6.0)
    assert cleared.tolist() == [
        True,
        True,
        False,
        False,
        False,
        True,
        False,
        False,
        False,
    ]


def test_seen_again_uses_the_camera_pose():
    # The camera at [10, 0, 0] looking along world −x: R_WC maps C's z to −x.
    R_WC = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    p_WC = np.array([10.0, 0.0, 0.0])
    depth = np.full((CAMERA.height, CAMERA.width), 3.0)
    points = np.array([[8.0, 0.0, 0.0], [6.0, 0.0, 0.0], [12.0, 0.0, 0.0]])
    cleared = seen_again(points, R_WC.T, -R_WC.T @ p_WC, CAMERA, depth, 6.0)
    assert cleared.tolist() == [True, False, False]


def test_remember_forgets_by_age_and_by_distance_and_adds_the_frame():
    memory = Memory(
        np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [9.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        np.array([0.5, 1.0, 1.0, 1.0]),
    )
    cleared = np.array([False, False, False, True])
    new = np.array([[0.0, 0.0, 2.0]])
    after = remember(memory, cleared, new, 2.6, np.zeros(3), duration=2.0, reach=6.0)
    # [1, 0, 0] is 2.1 s old, [9, 0, 0] 9 m away, [0, 1, 0] cleared.
    np.testing.assert_array_equal(after.points, [[2.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    np.testing.assert_array_equal(after.times, [1.0, 2.6])


def bfs_components(n, edges):
    """Labels by breadth-first search (the oracle)."""
    neighbours = [[] for _ in range(n)]
    for a, b in edges:
        neighbours[a].append(b)
        neighbours[b].append(a)
    label = [-1] * n
    for start in range(n):
        if label[start] < 0:
            label[start], queue = start, [start]
            while queue:
                for m in neighbours[queue.pop()]:
                    if label[m] < 0:
                        label[m] = start
                        queue.append(m)
    return label


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 40).flatmap(
        lambda n: st.tuples(
            st.just(n),
            st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1))),
        )
    )
)
def test_components_match_breadth_first_search(graph):
    n, edges = graph
    edges = np.array(edges, dtype=int).reshape(-1, 2)
    labels = components(n, edges[:, 0], edges[:, 1])
    # Both label each node by the smallest node of its component.
    assert labels.tolist() == bfs_components(n, edges.tolist())


def box_closest_point(low, high, p) -> np.ndarray:
    """The closed form: p clamped into the box."""
    return np.clip(p, low, high)


def visible(points, normals, p) -> np.ndarray:
    """The points whose outward normal faces p (what a camera at p sees of a
    convex obstacle)."""
    return points[np.sum(normals * (p - points), axis=1) > 0.0]


def box_seen_from(low, high, p, step=0.05) -> np.ndarray:
    """Samples `step` apart on the faces of the box [low, high] facing p."""
    low, high = np.asarray(low, float), np.asarray(high, float)
    axes = [np.arange(lo, hi + 1e-9, step) for lo, hi in zip(low, high, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    normals = np.isclose(grid, high).astype(float) - np.isclose(grid, low)
    on_face = np.any(normals != 0.0, axis=1)
    return visible(grid[on_face], normals[on_face], p)


def sphere_seen_from(centre, radius, p, count=4000) -> np.ndarray:
    """A Fibonacci lattice of samples on the sphere, those facing p."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    phi = np.pi * (1.0 + 5**0.5) * k
    n = np.stack(
        [np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1
    )
    return visible(np.asarray(centre) + radius * n, n, p)


def readings(points, p, count=3) -> np.ndarray:
    """The vectors to the nearest sample of each of the nearest basins."""
    graph = voxel_graph(points)
    basins = nearest_basins(points, graph, p, count)
    mine = np.isin(graph.voxel_of, basins)
    return Groups.of(points[mine], graph.voxel_of[mine]).nearest(p)


P = np.array([0.0, 0.0, 0.0])


def test_one_box_is_one_reading_at_its_closest_point():
    low, high = [1.0, -0.7, -0.4], [1.6, 0.9, 0.8]
    seen = readings(box_seen_from(low, high, P), P)
    assert len(seen) == 1
    np.testing.assert_allclose(seen[0], box_closest_point(low, high, P), atol=0.05)


def test_two_separated_boxes_are_two_readings_nearest_first():
    boxes = [([1.0, -1.5, -0.5], [1.5, -0.5, 0.5]), ([2.0, 0.3, -0.2], [2.5, 1.0, 0.4])]
    points = np.concatenate([box_seen_from(lo, hi, P) for lo, hi in boxes])
    seen = readings(points, P)
    exact = [box_closest_point(lo, hi, P) for lo, hi in boxes]
    assert len(seen) == 2
    np.testing.assert_allclose(seen, exact, atol=0.05)


def union_of_spheres(centres, radius) -> np.ndarray:
    """Samples of the surface of a union of spheres, as seen from P."""
    points = np.concatenate([sphere_seen_from(c, radius, P) for c in centres])
    inside = [np.linalg.norm(points - c, axis=1) < radius - 1e-9 for c in centres]
    return points[~np.any(inside, axis=0)]


def test_overlapping_spheres_are_a_reading_each():
    # Spheres of radius 0.6 whose centres are 1.1 m apart: one connected
    # surface, two obstacles (each pole 1.47 m away bulges 0.29 m toward
    # the vehicle from the groove between them, 1.76 m away).
    centres = [np.array([2.0, -0.55, 0.0]), np.array([2.0, 0.55, 0.0])]
    exact = [c - 0.6 * c / np.linalg.norm(c) for c in centres]
    seen = readings(union_of_spheres(centres, 0.6), P)
    assert len(seen) == 2
    order = np.argsort([seen[0][1], seen[1][1]])
    np.testing.assert_allclose(seen[order], exact, atol=0.05)


def test_a_dip_shallower_than_dip_is_not_another_obstacle():
    # Centres 0.6 m apart: each pole (1.42 m away) lies only 0.06 m below the
    # groove (1.48 m) on the way to the other (less on the voxels, whose
    # distance is their nearest sample's), so the union is one obstacle,
    # read at either pole (both are equally near).
    centres = [np.array([2.0, -0.3, 0.0]), np.array([2.0, 0.3, 0.0])]
    points = union_of_spheres(centres, 0.6)
    exact = centres[0] - 0.6 * centres[0] / np.linalg.norm(centres[0])
    seen = readings(points, P)
    assert len(seen) == 1
    assert np.linalg.norm(seen[0]) == pytest.approx(np.linalg.norm(exact), abs=0.02)
    # Without the dip test both poles are minima.
    graph = voxel_graph(points)
    assert len(nearest_basins(points, graph, P, 3, dip=0.0)) == 2


def test_readings_of_a_voxel_are_its_nearest_sample_as_the_vehicle_moves():
    rng = np.random.default_rng(3)
    points = rng.uniform(-2.0, 2.0, (80, 3))
    labels = rng.integers(0, 6, 80)
    groups = Groups.of(points, labels)
    for p in rng.uniform(-1.0, 1.0, (5, 3)):
        best = {}
        for q, label in zip(points, labels, strict=True):
            if label not in best or np.linalg.norm(q - p) < np.linalg.norm(
                best[label] - p
            ):
                best[label] = q
        expected = sorted((q - p for q in best.values()), key=np.linalg.norm)
        np.testing.assert_allclose(groups.nearest(p), expected)


def test_an_empty_memory_reads_nothing():
    empty = Groups.of(np.zeros((0, 3)), np.zeros(0, dtype=int))
    assert empty.nearest(np.zeros(3)).shape == (0, 3)
    graph = voxel_graph(np.zeros((0, 3)))
    assert graph.count == 0
    assert nearest_basins(np.zeros((0, 3)), graph, np.zeros(3), 3).shape == (0,)
    frame = Frame(np.zeros((0, 3)), np.zeros(0, dtype=int), (2, 2))
    assert surface_links(frame).shape == (0, 2)
