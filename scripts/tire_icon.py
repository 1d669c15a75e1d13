"""The FMU's icon: a tire seen from the side, drawn procedurally and written as a PNG.

    png = tire_png()           # 256 x 256 RGBA, transparent background, the same bytes every time

The picture: a dark tread ring whose outer band is cut into tread blocks, a dark grey
sidewall, a light grey rim with five windows, and a grey hub with five bolt holes and a
centre bore. Each pixel is the mean of SUPERSAMPLE x SUPERSAMPLE samples (anti-aliasing).

Reproducible: on the sample grid only +, -, *, / and sqrt are used (IEEE 754 rounds them
exactly, so every machine and numpy build gives the same samples); the few angles are
Python floats made once; the averaging is done in integers. The PNG has no time stamp or
other metadata, and zlib compresses it at level 9.
"""

from __future__ import annotations

import math
import struct
import zlib

import numpy as np

SIZE = 256
SUPERSAMPLE = 4

# Radii as fractions of half the image width.
TREAD_OUTER = 0.97
TREAD_BLOCKS_INNER = 0.86     # the outer band from here to TREAD_OUTER is cut into blocks
TREAD_INNER = 0.78            # the tread ring ends here; the sidewall begins
SIDEWALL_INNER = 0.56         # the rim flange begins
RIM_INNER = 0.50              # the rim's face begins
WINDOW_OUTER, WINDOW_INNER = 0.46, 0.27
HUB = 0.23
BOLT_CIRCLE, BOLT_HOLE = 0.145, 0.034
BORE = 0.065

TREAD_BLOCKS = 28
GROOVE_FRACTION = 0.36        # share of each block's pitch that is groove (empty)
WINDOWS, WINDOW_FRACTION = 5, 0.55
BOLTS = 5

LIGHT = (-0.6, 0.8)            # direction the light comes from (unit vector, y up)

# Colours (sRGB)
TREAD = (28, 28, 30)
SIDEWALL_DARK, SIDEWALL_LIGHT = (40, 41, 44), (78, 80, 85)
SIDEWALL_LINE = (98, 100, 106)
RIM_FLANGE = (150, 155, 162)
RIM_FACE_DARK, RIM_FACE_LIGHT = (168, 173, 180), (214, 218, 223)
WINDOW = (52, 54, 58)
HUB_COLOUR = (128, 134, 142)
HOLE = (36, 37, 40)


def _directions(count: int, offset: float) -> list[tuple[float, float]]:
    """Unit vectors at angles offset + k 2 pi / count (made once, in Python floats)."""
    return [(math.cos(offset + 2.0 * math.pi * k / count), math.sin(offset + 2.0 * math.pi * k / count))
            for k in range(count)]


def _in_sectors(x, y, count: int, fraction: float, offset: float):
    """True where the point's angle lies in one of `count` equal sectors, each `fraction`
    of its pitch wide and centred on offset + k 2 pi / count. Cross products only (no atan2)."""
    half = math.pi * fraction / count
    inside = np.zeros(x.shape, dtype=bool)
    for (cs, sn) in _directions(count, offset):
        # the sector's two edges, rotated by -half and +half from its centre line
        c1, s1 = cs * math.cos(half) + sn * math.sin(half), sn * math.cos(half) - cs * math.sin(half)
        c2, s2 = cs * math.cos(half) - sn * math.sin(half), sn * math.cos(half) + cs * math.sin(half)
        inside |= (c1 * y - s1 * x >= 0.0) & (x * s2 - y * c2 >= 0.0) & (x * cs + y * sn > 0.0)
    return inside


def _mix(dark, light, t):
    """Per-sample colour between two colours, t in [0, 1] (array), as uint8 channels."""
    t = np.clip(t, 0.0, 1.0)
    return [np.floor(d + (l - d) * t + 0.5).astype(np.int64) for d, l in zip(dark, light)]


def render(size: int = SIZE, supersample: int = SUPERSAMPLE) -> np.ndarray:
    """The icon as a (size, size, 4) uint8 RGBA array (row 0 at the top)."""
    n = size * supersample
    # sample centres in [-1, 1], y up
    coords = (np.arange(n, dtype=np.float64) * 2.0 + 1.0) / n - 1.0
    x = np.broadcast_to(coords[np.newaxis, :], (n, n))
    y = np.broadcast_to(-coords[:, np.newaxis], (n, n))
    r = np.sqrt(x * x + y * y)

    red = np.zeros((n, n), dtype=np.int64)
    green = np.zeros_like(red)
    blue = np.zeros_like(red)
    alpha = np.zeros((n, n), dtype=bool)

    def paint(mask, colour):
        nonlocal red, green, blue
        if not isinstance(colour, list):  # one colour for every sample
            colour = [np.full((n, n), c, dtype=np.int64) for c in colour]
        channels = colour
        red = np.where(mask, channels[0], red)
        green = np.where(mask, channels[1], green)
        blue = np.where(mask, channels[2], blue)
        alpha[mask] = True

    # Tread: a solid inner ring and an outer band of blocks separated by grooves.
    blocks = _in_sectors(x, y, TREAD_BLOCKS, 1.0 - GROOVE_FRACTION, 0.0)
    paint((r <= TREAD_BLOCKS_INNER) & (r > TREAD_INNER), TREAD)
    paint((r <= TREAD_OUTER) & (r > TREAD_BLOCKS_INNER) & blocks, TREAD)
    # Sidewall, lit from the upper left (LIGHT): brighter towards the light, the more so the
    # further out (a bulging sidewall), with a thin moulded line.
    towards_light = (LIGHT[0] * x + LIGHT[1] * y) / np.maximum(r, 1e-9)
    outwards = (r - SIDEWALL_INNER) / (TREAD_INNER - SIDEWALL_INNER)
    sidewall = (r <= TREAD_INNER) & (r > SIDEWALL_INNER)
    light = 0.5 + 0.5 * towards_light * outwards
    paint(sidewall, _mix(SIDEWALL_DARK, SIDEWALL_LIGHT, light))
    paint(sidewall & (np.abs(r - 0.70) < 0.008), SIDEWALL_LINE)
    # Rim: flange, face (a radial gradient), windows between face and hub.
    paint((r <= SIDEWALL_INNER) & (r > RIM_INNER), RIM_FLANGE)
    face = r <= RIM_INNER
    paint(face, _mix(RIM_FACE_DARK, RIM_FACE_LIGHT, 0.55 + 0.45 * (LIGHT[0] * x + LIGHT[1] * y)))
    windows = _in_sectors(x, y, WINDOWS, WINDOW_FRACTION, math.pi / 2.0 + math.pi / WINDOWS)
    paint(face & (r <= WINDOW_OUTER) & (r > WINDOW_INNER) & windows, WINDOW)
    # Hub with bolt holes and the centre bore.
    paint(r <= HUB, HUB_COLOUR)
    for (cs, sn) in _directions(BOLTS, math.pi / 2.0):
        dx, dy = x - BOLT_CIRCLE * cs, y - BOLT_CIRCLE * sn
        paint(dx * dx + dy * dy <= BOLT_HOLE * BOLT_HOLE, HOLE)
    paint(r <= BORE, HOLE)

    # Average each supersample block: premultiplied sums in integers.
    def block_sum(a):
        return a.reshape(size, supersample, size, supersample).sum(axis=(1, 3))

    cover = block_sum(alpha.astype(np.int64))
    samples = supersample * supersample
    out = np.zeros((size, size, 4), dtype=np.uint8)
    safe = np.maximum(cover, 1)
    for i, channel in enumerate((red, green, blue)):
        total = block_sum(np.where(alpha, channel, 0))
        out[..., i] = np.where(cover > 0, (2 * total + safe) // (2 * safe), 0)
    out[..., 3] = (cover * 255 * 2 + samples) // (2 * samples)
    return out


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(rgba: np.ndarray) -> bytes:
    """An RGBA image (height, width, 4 uint8) as PNG bytes: IHDR, one IDAT, IEND."""
    height, width, channels = rgba.shape
    assert channels == 4 and rgba.dtype == np.uint8
    raw = b"".join(b"\x00" + rgba[row].tobytes() for row in range(height))  # filter 0 (None)
    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)  # 8 bit RGBA, no interlace
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(raw, 9))
            + _chunk(b"IEND", b""))


def tire_png(size: int = SIZE) -> bytes:
    return png_bytes(render(size))


if __name__ == "__main__":
    import sys

    out = sys.argv[1] if len(sys.argv) > 1 else "tire.png"
    with open(out, "wb") as f:
        f.write(tire_png())
    print(out)
