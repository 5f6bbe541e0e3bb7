"""8-bit grey PNGs for the Python tests, built with zlib and struct (no image library here)."""
import struct
import zlib


def png_chunk(kind, data):
    """One PNG chunk: length, type, data and CRC."""
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def grey_png(width, height, row_of, colour_type=0):
    """A PNG whose row y holds the bytes row_of(y): `width` of them (grey), 3 x `width` (RGB,
    colour_type 2), 4 x `width` (RGBA, colour_type 6)."""
    chunk = png_chunk
    rows = b"".join(b"\0" + row_of(y) for y in range(height))
    return (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def pattern_png(width, height, seed):
    """A smooth pattern that differs with `seed`: distinct uploads, distinct textons."""
    return grey_png(width, height, lambda y: bytes(
        ((x * 7 + y * 13 + seed * 31 + (x * y) % 17) * 5) % 256 for x in range(width)))


def ramp_png(width, height, period=64, colour=False):
    """One repeated ramp: small on the wire whatever size it declares (RGB, colour type 2, with
    `colour`: its three channels three phases of it)."""
    if colour:
        row = bytes((x * 255 // period + 85 * c) % 256 for x in range(period)
                    for c in range(3)) * (width // period)
        return grey_png(width, height, lambda y: row, colour_type=2)
    row = bytes((x * 255 // period) % 256 for x in range(period)) * (width // period)
    return grey_png(width, height, lambda y: row)


def rgba_png(width, height, seed):
    """An RGBA PNG whose four channels are four different patterns (a splat's four weights)."""
    return grey_png(width, height, lambda y: bytes(
        ((x * (7 + c) + y * (13 - c) + seed * 31 + c * 50) * 5) % 256
        for x in range(width) for c in range(4)), colour_type=6)
