"""A numpy-only renderer: discs coloured by species, the walls, and a small legend.

An adapter at the edge: it reads a :class:`~discgym.Simulation` and returns an RGB image;
the physics never imports it.

>>> import discgym as dg
>>> from discgym.render import render_frame
>>> img = render_frame(dg.Simulation("ideal_gas", seed=0), size=200)
>>> img.shape, img.dtype.name
((200, 200, 3), 'uint8')
"""

from __future__ import annotations

import numpy as np

from .scene import Box

__all__ = ["render_frame", "species_colors", "draw_text", "PALETTE"]

#: Species colours (RGB), in scene order; a scene with more species cycles through them.
PALETTE = np.array(
    [
        (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
        (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
    ],
    dtype=np.uint8,
)

BACKGROUND = np.array((250, 250, 247), dtype=np.uint8)
WALL = np.array((40, 40, 40), dtype=np.uint8)
OUTSIDE = np.array((225, 225, 222), dtype=np.uint8)

# 3x5 bitmap font: each glyph is 5 rows of 3 bits.
_FONT = {
    "A": "010101111101101", "B": "110101110101110", "C": "011100100100011",
    "D": "110101101101110", "E": "111100110100111", "F": "111100110100100",
    "G": "011100101101011", "H": "101101111101101", "I": "111010010010111",
    "J": "001001001101010", "K": "101101110101101", "L": "100100100100111",
    "M": "101111111101101", "N": "110101101101101", "O": "010101101101010",
    "P": "110101110100100", "Q": "010101101110011", "R": "110101110101101",
    "S": "011100010001110", "T": "111010010010010", "U": "101101101101111",
    "V": "101101101101010", "W": "101101111111101", "X": "101101010101101",
    "Y": "101101010010010", "Z": "111001010100111", "0": "111101101101111",
    "1": "010110010010111", "2": "110001010100111", "3": "110001010001110",
    "4": "101101111001001", "5": "111100110001110", "6": "011100110101010",
    "7": "111001010010010", "8": "010101010101010", "9": "010101011001110",
    ".": "000000000000010", ",": "000000000010100", ":": "000010000010000",
    "-": "000000111000000", "+": "000010111010000", "=": "000111000111000",
    "_": "000000000000111", "/": "001001010100100", "(": "010100100100010",
    ")": "010001001001010", "%": "101001010100101", " ": "000000000000000",
    ">": "100010001010100", "<": "001010100010001", "*": "000101010101000",
}


def species_colors(n: int) -> np.ndarray:
    """(n, 3) uint8 colours for n species."""
    return PALETTE[np.arange(n) % len(PALETTE)]


def draw_text(img: np.ndarray, text: str, x: int, y: int, color=(20, 20, 20),
              scale: int = 2) -> int:
    """Draw ``text`` (upper-cased) with the top-left corner at pixel (x, y); returns the x
    just after it. Characters without a glyph are drawn as blanks."""
    col = np.asarray(color, dtype=np.uint8)
    h, w = img.shape[:2]
    for ch in text.upper():
        bits = _FONT.get(ch, _FONT[" "])
        for k, b in enumerate(bits):
            if b == "1":
                r, c = divmod(k, 3)
                y0, x0 = y + r * scale, x + c * scale
                if 0 <= y0 < h and 0 <= x0 < w:
                    img[y0:min(y0 + scale, h), x0:min(x0 + scale, w)] = col
        x += 4 * scale
    return x


def render_frame(sim, size: int = 400, legend: bool = True, title: str | None = None
                 ) -> np.ndarray:
    """An RGB image (size, size, 3) uint8 of the simulation's current state.

    Discs are filled with their species' colour, the bounds are drawn as a dark outline and,
    if ``legend``, each species' colour and count are listed in the top-left corner.
    """
    size = int(size)
    img = np.empty((size, size, 3), dtype=np.uint8)
    img[:] = BACKGROUND
    x0, y0, x1, y1 = sim.bounds.extent
    margin = 4
    span = max(x1 - x0, y1 - y0)
    scale = (size - 2 * margin) / span
    ox = margin + 0.5 * ((size - 2 * margin) - (x1 - x0) * scale)
    oy = margin + 0.5 * ((size - 2 * margin) - (y1 - y0) * scale)

    def to_px(x, y):  # y up in the world, down in the image
        return ox + (x - x0) * scale, size - (oy + (y - y0) * scale)

    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64) + 0.5
    bounds = sim.bounds
    if isinstance(bounds, Box):
        px0, py1 = to_px(x0, y0)
        px1, py0 = to_px(x1, y1)
        inside = (xx >= px0) & (xx <= px1) & (yy >= py0) & (yy <= py1)
        edge = inside & ~((xx >= px0 + 2) & (xx <= px1 - 2) & (yy >= py0 + 2) & (yy <= py1 - 2))
    else:
        cx, cy = to_px(*bounds.center)
        rr = bounds.radius * scale
        d2 = (xx - cx) ** 2 + (yy - cy) ** 2
        inside = d2 <= rr**2
        edge = inside & (d2 >= (rr - 2) ** 2)
    img[~inside] = OUTSIDE
    img[edge] = WALL

    colors = species_colors(len(sim.scene.species))
    pos = sim.positions
    rad = sim.radii
    spc = sim.species
    for (x, y), r, s in zip(pos, rad, spc):
        px, py = to_px(x, y)
        pr = max(r * scale, 0.7)
        i0, i1 = int(max(py - pr, 0)), int(min(py + pr + 1, size))
        j0, j1 = int(max(px - pr, 0)), int(min(px + pr + 1, size))
        if i0 >= i1 or j0 >= j1:
            continue
        sub = (xx[i0:i1, j0:j1] - px) ** 2 + (yy[i0:i1, j0:j1] - py) ** 2 <= pr * pr
        img[i0:i1, j0:j1][sub] = colors[s]
    img[edge] = WALL

    if legend:
        fs = 2 if size >= 240 else 1
        y = 6
        counts = sim.counts()
        lines = [f"{sp.name} {counts[sp.name]}" for sp in sim.scene.species]
        width = max(len(t) for t in lines + [title or ""]) * 4 * fs + 7 * fs + 12
        height = (len(lines) + (1 if title else 0)) * 7 * fs + 8
        img[2:2 + height, 2:2 + width] = (255, 255, 255)
        if title:
            draw_text(img, title, 8, y, scale=fs)
            y += 7 * fs
        for k, text in enumerate(lines):
            img[y:y + 5 * fs, 8:8 + 5 * fs] = colors[k]
            draw_text(img, text, 8 + 7 * fs, y, scale=fs)
            y += 7 * fs
    return img
