"""Obstacle readings from depth images: the depth camera's perception as plain
numpy, so that each step can be tested alone (docs/depth_camera.md).

Each frame of a camera, with the vehicle's estimated pose, becomes readings
in four steps:

1. `Thinning`: each BLOCK×BLOCK block of pixels keeps the one return nearest the
   vehicle centre. The samples are measured points (not averages), and the
   closest seen point of every obstacle survives unless a nearer obstacle
   shares its block.
2. `remember`: the memory holds samples in the world frame with the time
   they were seen. A frame clears every remembered sample it shows free
   space at, or sees again, along that sample's pixel (`seen_again`); the
   memory also drops samples older than T and those farther from the
   vehicle than the cameras reach. The frame's samples then join it.
3. `voxel_graph`: the memory's occupied voxels (VOXEL), neighbours in the
   26-neighbourhood and also where neighbouring blocks of the new frame lie
   on one surface (`surface_links`: a wall seen edge-on is sampled ever
   more sparsely with range, but stays one surface).
4. `nearest_basins`: an obstacle is a local minimum of the distance to the
   vehicle on that graph that persists (it is not a dip of less than DIP
   on the way to a deeper one); the readings are the nearest sample
   of each of the nearest minima, nearest first (the reading of `layout`),
   re-read from that minimum's voxel as the vehicle moves until the next
   frame.

Frames: C is Drake's camera frame (+z along the view, +x image right, +y
image down); the depth image holds z-depths (inf: no return within range;
0: closer than the camera's minimum depth). Lengths in metres.
"""

import functools
from dataclasses import dataclass

import numpy as np

BLOCK = 4  # pixels per side of the blocks a frame is thinned to
# Voxel edge [m]: samples within one voxel edge of each other (per axis) are
# always joined, up to two edges possibly. Gaps that small are narrower than
# either vehicle (collision diameter ≥ 0.45 m), so nothing is lost by
# treating the obstacles on both sides as one.
VOXEL = 0.2
# Neighbouring blocks are one surface when they fit a plane at least this far
# from the camera [m]: below the collision radius of either vehicle, so any
# wall the vehicle can be beside without touching qualifies.
SURFACE_DISTANCE = 0.2
# A local minimum of the distance that rises less than this [m] on the way to
# a deeper one is not another obstacle: about the samples' spacing 1.5 m away
# (4 pixels of 0.5°), where MFI's boundary following starts.
DIP = 0.05
# A remembered sample within this distance [m] in front of or behind the
# measured depth along its pixel counts as seen again (covers the pixel's
# footprint at a grazing view and the pose estimate's drift between frames).
DEPTH_MARGIN = 0.1

# Voxel keys: three indices packed into one int64 (±2^20 voxels a side).
_KEY_BITS = 21
_KEY_OFFSET = 1 << (_KEY_BITS - 1)
# The 13 neighbours of the 26-neighbourhood that come after a voxel in key
# order; each pair of neighbours is looked up once, from its first voxel.
_NEIGHBOURS = np.array(
    [
        (dx << (2 * _KEY_BITS)) + (dy << _KEY_BITS) + dz
        for dx in (-1, 0, 1)
        for dy in (-1, 0, 1)
        for dz in (-1, 0, 1)
        if (dx, dy, dz) > (0, 0, 0)
    ],
    dtype=np.int64,
)


@dataclass(frozen=True)
class Intrinsics:
    """A pinhole camera: pixel (u, v) sees the ray [(u − c_x)/f_x,
    (v − c_y)/f_y, 1] (Drake's `CameraInfo` convention)."""

    width: int
    height: int
    focal_x: float
    focal_y: float
    center_x: float
    center_y: float


@dataclass(frozen=True)
class Frame:
    """One camera's thinned frame: samples in the camera frame C and the
    block each came from (row-major on the block grid)."""

    points: np.ndarray  # (n, 3), C
    blocks: np.ndarray  # (n,) int
    grid: tuple[int, int]  # (rows, columns) of blocks


@dataclass(frozen=True)
class Memory:
    """Remembered samples, world frame, with the time each was seen."""

    points: np.ndarray  # (m, 3)
    times: np.ndarray  # (m,)

    @staticmethod
    def empty() -> "Memory":
        return Memory(np.zeros((0, 3)), np.zeros(0))


class Thinning:
    """Step 1 for one camera: which return of each BLOCK×BLOCK block of
    pixels is nearest `centre` (the vehicle centre in C), chosen on the
    depth image itself. A pixel at z-depth z sees the point z·ρ (its ray ρ,
    `rays` (3, height·width) with ρ_z = 1, row-major like the image), so
    |z·ρ − c|² = z (z |ρ|² − 2 ρ·c) + |c|² needs two products a pixel. The
    blocks of the last row and column may be partial."""

    def __init__(self, rays: np.ndarray, width: int, height: int, centre):
        self.width, self.height = width, height
        rows, cols = -(-height // BLOCK), -(-width // BLOCK)
        self.grid = (rows, cols)
        # float32 like the image: float64 temporaries of a whole image (150
        # kB) are big enough for malloc to map and unmap them every time.
        self._a = np.sum(rays * rays, axis=0).reshape(height, width).astype(np.float32)
        self._b = (-2.0 * np.asarray(centre) @ rays).reshape(height, width)
        self._b = self._b.astype(np.float32)
        self._c = np.float32(np.dot(centre, centre))

    def __call__(self, points: np.ndarray, depth: np.ndarray) -> Frame:
        """The frame of an organized cloud `points` (3, height·width) and its
        depth image (height, width): z-depths, inf for no return, 0 for too
        close (no sample either)."""
        z = depth.astype(np.float32)
        d2 = z * (z * self._a + self._b) + self._c
        d2[~(z > 0.0)] = np.inf
        rows, cols = self.grid
        padded = d2
        if padded.shape != (rows * BLOCK, cols * BLOCK):
            padded = np.full((rows * BLOCK, cols * BLOCK), np.inf, dtype=d2.dtype)
            padded[: self.height, : self.width] = d2
        per_block = padded.reshape(rows, BLOCK, cols, BLOCK).swapaxes(1, 2)
        per_block = per_block.reshape(rows * cols, BLOCK * BLOCK)
        best = np.argmin(per_block, axis=1)
        blocks = np.flatnonzero(np.isfinite(per_block[np.arange(rows * cols), best]))
        best = best[blocks]
        v = (blocks // cols) * BLOCK + best // BLOCK
        u = (blocks % cols) * BLOCK + best % BLOCK
        return Frame(points[:, v * self.width + u].T, blocks, self.grid)


@functools.cache
def _neighbour_blocks(rows: int, cols: int) -> tuple[np.ndarray, np.ndarray]:
    """(a, b): each pair of blocks of a rows × cols grid side by side (across)
    or one above the other (down), row-major indices."""
    index = np.arange(rows * cols).reshape(rows, cols)
    a = np.concatenate([index[:, :-1].ravel(), index[:-1, :].ravel()])
    b = np.concatenate([index[:, 1:].ravel(), index[1:, :].ravel()])
    return a, b


def surface_links(frame: Frame, distance: float = SURFACE_DISTANCE) -> np.ndarray:
    """(k, 2) pairs of samples of `frame` in neighbouring blocks (across and
    down) that fit a plane at least `distance` from the camera.

    On a plane n·X = c (|n| = 1, c its distance from the camera centre)
    the inverse depth 1/z = n·ρ/c is affine in the pixel's ray ρ = X/z, so
    two of its samples differ by |Δ(1/z)| ≤ |Δρ|/c, however obliquely it is
    seen. Two samples with |Δ(1/z)| · distance ≤ |Δρ| are therefore joined;
    a depth jump at an occluding edge is larger and is not."""
    rows, cols = frame.grid
    index = np.full(rows * cols, -1)
    index[frame.blocks] = np.arange(len(frame.blocks))
    a, b = _neighbour_blocks(rows, cols)
    i, j = index[a], index[b]
    both = (i >= 0) & (j >= 0)
    i, j = i[both], j[both]
    z = frame.points[:, 2]
    w = (distance / z).astype(float)
    x = (frame.points[:, 0] / z).astype(float)
    y = (frame.points[:, 1] / z).astype(float)
    joined = np.abs(w[i] - w[j]) <= np.hypot(x[i] - x[j], y[i] - y[j])
    return np.stack([i[joined], j[joined]], axis=1)


def seen_again(
    points: np.ndarray,
    R_CW: np.ndarray,
    p_CW: np.ndarray,
    camera: Intrinsics,
    depth: np.ndarray,
    max_range: float,
    margin: float = DEPTH_MARGIN,
) -> np.ndarray:
    """Which world points (m, 3) a frame clears: those in its view frustum
    (in front of the camera, projecting into the image at least BLOCK
    pixels from its edge) that are not hidden behind what their pixel
    measured, i.e. z < depth + margin. A pixel with no return shows free
    space up to max_range; one closer than the minimum depth (0) shows none.

    The outermost BLOCK pixels clear nothing: the edge of the image is the
    edge of what was seen, not of the obstacle, and there the thinned frame
    (one sample a block, up to BLOCK − 1 pixels in) would not replace what
    it cleared, cutting the remembered surface beyond the edge off the
    surface in view.

    X_CW = (R_CW, p_CW) is the camera pose the frame is placed with."""
    q = points @ R_CW.T + p_CW
    ahead = np.flatnonzero(q[:, 2] > 0.0)
    x, y, z = q[ahead].T
    u = np.rint(camera.focal_x * x / z + camera.center_x)
    v = np.rint(camera.focal_y * y / z + camera.center_y)
    inside = (u >= BLOCK) & (u < camera.width - BLOCK)
    inside &= (v >= BLOCK) & (v < camera.height - BLOCK)
    measured = depth[v[inside].astype(int), u[inside].astype(int)].astype(float)
    limit = measured + margin
    limit[np.isinf(measured)] = max_range
    limit[measured <= 0.0] = 0.0
    cleared = np.zeros(len(q), dtype=bool)
    cleared[ahead[inside]] = z[inside] < limit
    return cleared


def remember(
    memory: Memory,
    cleared: np.ndarray,
    new_points: np.ndarray,
    time: float,
    position: np.ndarray,
    duration: float,
    reach: float,
) -> Memory:
    """The memory after a frame at `time`: without the `cleared` samples,
    those seen `duration` or more ago and those farther than `reach` from
    `position`; with the frame's `new_points` (world frame) added."""
    near = squared_distances(memory.points.T, position) <= reach * reach
    keep = ~cleared & (time - memory.times < duration) & near
    return Memory(
        np.concatenate([memory.points[keep], new_points]),
        np.concatenate([memory.times[keep], np.full(len(new_points), float(time))]),
    )


@dataclass(frozen=True)
class VoxelGraph:
    """The samples' occupied voxels and which of them are neighbours."""

    voxel_of: np.ndarray  # (m,) the voxel of each sample
    count: int  # voxels
    a: np.ndarray  # (e,) edges (a_i, b_i) between voxels
    b: np.ndarray


def voxel_graph(
    points: np.ndarray, links: np.ndarray | None = None, voxel: float = VOXEL
) -> VoxelGraph:
    """The graph of the occupied voxels of `points` (m, 3): an edge between
    each two of the 26-neighbourhood, and one for each pair of samples in
    `links` ((k, 2) indices, `surface_links`) that lie in different voxels."""
    cells = np.floor(points / voxel).astype(np.int64) + _KEY_OFFSET
    keys = (cells[:, 0] << (2 * _KEY_BITS)) | (cells[:, 1] << _KEY_BITS) | cells[:, 2]
    occupied, voxel_of = np.unique(keys, return_inverse=True)
    if len(occupied) == 0:
        return VoxelGraph(voxel_of, 0, voxel_of, voxel_of)
    wanted = (occupied[:, None] + _NEIGHBOURS).ravel()
    found = np.minimum(np.searchsorted(occupied, wanted), len(occupied) - 1)
    hit = occupied[found] == wanted
    a = np.repeat(np.arange(len(occupied)), len(_NEIGHBOURS))[hit]
    b = found[hit]
    if links is not None and len(links):
        a = np.concatenate([a, voxel_of[links[:, 0]]])
        b = np.concatenate([b, voxel_of[links[:, 1]]])
    return VoxelGraph(voxel_of, len(occupied), a, b)


def components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Connected components of the graph on nodes 0…n−1 with edges (a_i,
    b_i): each node's label is the smallest node of its component.

    Every round hooks the larger root of each edge whose ends differ onto
    the smaller one, then follows the pointers to the roots (pointer
    jumping); labels only decrease, so the rounds end."""
    label = np.arange(n)
    while True:
        la, lb = label[a], label[b]
        differ = la != lb
        if not differ.any():
            return label
        la, lb = la[differ], lb[differ]
        np.minimum.at(label, np.maximum(la, lb), np.minimum(la, lb))
        while True:
            jumped = label[label]
            if np.array_equal(jumped, label):
                break
            label = jumped


def nearest_basins(
    points: np.ndarray,
    graph: VoxelGraph,
    position: np.ndarray,
    count: int,
    dip: float = DIP,
) -> np.ndarray:
    """The voxels of the `count` nearest obstacles seen from `position`,
    nearest first: the local minima of the distance (a voxel's: that of its
    nearest sample) on the graph that persist, i.e. whose connected
    component among the voxels no farther than the minimum plus `dip`
    holds nothing nearer (ties to the lower voxel index).

    A convex obstacle has one minimum on its surface, a wall seen edge-on
    one (the distance grows along it), and obstacles that touch or overlap
    one each where each bulges toward the vehicle by more than about `dip`
    (on the voxels, whose distance is their nearest sample's). A
    minimum that rises less than that before reaching a deeper one is an
    artefact of the sampling (sparse or old samples of the same surface)."""
    d = np.sqrt(squared_distances(points.T, position))
    nearest = np.full(graph.count, np.inf)
    np.minimum.at(nearest, graph.voxel_of, d)
    return persistent_minima(nearest, graph.a, graph.b, count, dip)


def persistent_minima(
    nearest: np.ndarray, a: np.ndarray, b: np.ndarray, count: int, dip: float = DIP
) -> np.ndarray:
    """`nearest_basins` of a graph on voxels 0…len(nearest)−1 with edges
    (a_i, b_i), each voxel's distance `nearest` (its nearest sample's)."""
    voxels = len(nearest)
    # (d, index) of each end, compared lexicographically.
    a_first = (nearest[a] < nearest[b]) | ((nearest[a] == nearest[b]) & (a < b))
    beaten = np.zeros(voxels, dtype=bool)
    beaten[b[a_first]] = True
    beaten[a[~a_first & (a != b)]] = True
    minima = np.flatnonzero(~beaten)
    found = []
    for m in minima[np.argsort(nearest[minima], kind="stable")]:
        if len(found) == count:
            break
        if found:  # the nearest minimum always persists
            level = nearest[m] + dip
            low = (nearest[a] <= level) & (nearest[b] <= level)
            label = components(voxels, a[low], b[low])
            if nearest[label == label[m]].min() < nearest[m]:
                continue
        found.append(m)
    return np.array(found, dtype=int)


def squared_distances(xyz: np.ndarray, position: np.ndarray) -> np.ndarray:
    """|q − position|² of each column q of xyz (3, n), row by row (summing
    an (n, 3) array along its rows is several times slower), in xyz's
    precision: a whole image's float64 temporaries (150 kB each) are large
    enough for malloc to map and unmap them every time, ten times slower."""
    p = np.asarray(position, dtype=xyz.dtype)
    dx, dy, dz = xyz[0] - p[0], xyz[1] - p[1], xyz[2] - p[2]
    return dx * dx + dy * dy + dz * dz


@dataclass(frozen=True)
class Groups:
    """Points in groups: columns lo to hi − 1 of xyz (3, n) are a group's,
    for each (lo, hi) in bounds."""

    xyz: np.ndarray
    bounds: list[tuple[int, int]]

    @staticmethod
    def of(points: np.ndarray, labels: np.ndarray) -> "Groups":
        """The points (n, 3) grouped by their labels."""
        order = np.argsort(labels, kind="stable")
        starts = np.flatnonzero(np.diff(labels[order], prepend=-1)).tolist()
        ends = [*starts[1:], len(labels)] if starts else []
        bounds = list(zip(starts, ends, strict=True))
        return Groups(np.ascontiguousarray(points[order].T), bounds)

    def nearest(self, position: np.ndarray) -> np.ndarray:
        """(k, 3): the vector from `position` to each group's nearest point,
        nearest first."""
        d = self.xyz - position[:, None]
        d2 = np.einsum("ij,ij->j", d, d)
        best = [lo + int(np.argmin(d2[lo:hi])) for lo, hi in self.bounds]
        best.sort(key=d2.__getitem__)
        return d[:, best].T


# --- one frame of the rig -------------------------------------------------------
@dataclass(frozen=True)
class View:
    """One camera's frame, placed in the world with the pose estimate."""

    frame: Frame
    R_WC: np.ndarray
    p_WC: np.ndarray
    camera: Intrinsics
    depth: np.ndarray  # (height, width) z-depths
    max_range: float


@dataclass(frozen=True)
class Percept:
    """What the cameras know after a frame: the memory, and the samples of
    the voxel of each of the nearest obstacles (`nearest_basins`) seen from
    the vehicle at the frame, each read by its nearest sample until the next
    frame.

    Immutable (its arrays are never written after construction), so the
    copies Drake makes of a context's state share it."""

    memory: Memory
    basins: Groups

    def __deepcopy__(self, memo) -> "Percept":
        return self

    @staticmethod
    def empty() -> "Percept":
        return Percept(Memory.empty(), Groups(np.zeros((3, 0)), []))


def fuse(
    memory: Memory,
    views: list[View],
    time: float,
    position: np.ndarray,
    duration: float,
    reach: float,
) -> Memory:
    """Step 2: the memory after the rig's `views` at `time`, the vehicle at
    `position`; the views' samples are its last ones, in order."""
    cleared = np.zeros(len(memory.points), dtype=bool)
    for view in views:
        R_CW = view.R_WC.T
        cleared |= seen_again(
            memory.points,
            R_CW,
            -R_CW @ view.p_WC,
            view.camera,
            view.depth,
            view.max_range,
        )
    new = [view.frame.points @ view.R_WC.T + view.p_WC for view in views]
    return remember(
        memory, cleared, np.concatenate(new), time, position, duration, reach
    )


def read(
    memory: Memory, frames: list[Frame], position: np.ndarray, count: int
) -> Percept:
    """Steps 3 and 4: the percept of `memory`, whose last samples are the
    `frames`', seen from `position`; `count` readings."""
    links, start = [], len(memory.points) - sum(len(f.points) for f in frames)
    for frame in frames:
        links.append(surface_links(frame) + start)
        start += len(frame.points)
    graph = voxel_graph(memory.points, np.concatenate(links))
    basins = nearest_basins(memory.points, graph, position, count)
    chosen = np.zeros(graph.count, dtype=bool)
    chosen[basins] = True
    mine = chosen[graph.voxel_of]
    return Percept(memory, Groups.of(memory.points[mine], graph.voxel_of[mine]))


def perceive(
    before: Percept,
    views: list[View],
    time: float,
    position: np.ndarray,
    duration: float,
    reach: float,
    count: int,
) -> Percept:
    """The percept after the rig's `views` at `time` (steps 2–4 of the
    module docstring), the vehicle at `position`; `count` readings."""
    memory = fuse(before.memory, views, time, position, duration, reach)
    return read(memory, [view.frame for view in views], position, count)
