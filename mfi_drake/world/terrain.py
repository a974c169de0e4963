"""Gazebo's heightmap terrains (`<heightmap>`: an image of heights, its
`<size>` and `<pos>`) as what a flight reads: the ground at the terrain's
lowest level, and a box column over each cell of a coarse grid, as tall as
the terrain anywhere in its cell.

Gazebo's reading (gz-common's `ImageHeightmap`): a pixel's first channel
over its type's largest value (255, or 65535 for 16-bit images) times
size z is the height above pos z; the image spans size x × size y centred
on pos, its columns along +x and its top row at +y; between pixels the
surface is bilinear. A column stands on the ground at pos z and reaches
the highest pixel on or inside its cell, which no point of the bilinear
surface over the cell exceeds: the columns hold the terrain (never under
it), and overreach it by its relief within a cell.

At most `COLUMNS` cells a side (a terrain of 129 pixels a side, 129 m
wide: cells of 2.7 m): the sensor's query grows with the obstacles, and a
world of thousands stays a few seconds to load (docs/big_scenes.md).
"""

import numpy as np

COLUMNS = 48  # cells a side at most
FLAT = 1e-3  # m: a cell no higher than this above the ground has no column


def read_heights(path: str) -> np.ndarray:
    """The image's heights as fractions of size z, (rows, columns), row 0
    the image's top. Raises ValueError, one line, for an image that cannot
    be read or holds no 8- or 16-bit pixels."""
    from PIL import Image  # imported here: only a terrain pays for it

    try:
        with Image.open(path) as image:
            image.load()
            mode = image.mode
            if mode.startswith("I"):  # 16-bit (PIL reads 16-bit PNGs as "I")
                pixels, top = np.asarray(image, dtype=float), 65535.0
            elif mode in ("1", "L", "LA", "P", "RGB", "RGBA", "CMYK"):
                pixels = np.asarray(image.convert("RGB"), dtype=float)[..., 0]
                top = 255.0  # the first channel, as Gazebo reads it
            else:
                raise ValueError(f"holds {mode} pixels, not 8- or 16-bit ones")
    # PIL's kinds (a bomb: more pixels than PIL allows); the user needs one line
    except (OSError, SyntaxError, Image.DecompressionBombError) as e:
        raise ValueError(f"not readable as an image: {e}") from None
    if min(pixels.shape) < 2:
        raise ValueError(f"is {pixels.shape[1]} × {pixels.shape[0]} pixels: too few")
    return pixels / top


def _cells(samples: int) -> list[tuple[float, float]]:
    """Each cell's (start, end) along an axis of `samples` samples, in
    samples: at most COLUMNS equal cells."""
    edges = np.linspace(0.0, samples - 1, min(COLUMNS, samples - 1) + 1)
    return list(zip(edges[:-1], edges[1:], strict=True))


def _within(start: float, end: float) -> slice:
    """The samples on or inside a cell (start, end)."""
    return slice(int(np.floor(start)), int(np.ceil(end)) + 1)


def terrain_columns(
    heights: np.ndarray, size: list[float], pos: list[float]
) -> tuple[float, list[tuple[list[float], list[float]]]]:
    """(the ground's height, [(centre, box size)] of each column) in the
    heightmap's frame, for `heights` (`read_heights`) spanning size x ×
    size y, size z high, centred on pos (Gazebo's `<size>`, `<pos>`)."""
    rows, cols = heights.shape
    step_x, step_y = size[0] / (cols - 1), size[1] / (rows - 1)
    left, top = pos[0] - size[0] / 2, pos[1] + size[1] / 2
    columns = []
    for i0, i1 in _cells(rows):  # image rows: +y first
        for j0, j1 in _cells(cols):
            high = float(heights[_within(i0, i1), _within(j0, j1)].max()) * size[2]
            if high <= FLAT:
                continue
            x0, x1 = left + j0 * step_x, left + j1 * step_x
            y0, y1 = top - i1 * step_y, top - i0 * step_y
            centre = [(x0 + x1) / 2, (y0 + y1) / 2, pos[2] + high / 2]
            columns.append((centre, [x1 - x0, y1 - y0, high]))
    return pos[2], columns
