"""Minimal, dependency-free writers for the textures' files: 8-bit RGB PNG and half-float RGB
OpenEXR (uncompressed scanlines), byte for byte the same on every run."""

import struct
import zlib


def write_png(path, width, height, pixel):
    """Write an 8-bit RGB PNG; pixel(x, y) gives (r, g, b) in 0..255, y = 0 the top row."""
    rows = bytearray()
    for y in range(height):
        rows.append(0)  # filter type: none
        for x in range(width):
            rows.extend(bytes(max(0, min(255, int(c))) for c in pixel(x, y)))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(bytes(rows), 9)))
        f.write(chunk(b"IEND", b""))


def _attribute(name, kind, data):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data


def write_exr(path, width, height, pixel):
    """Write a scanline OpenEXR of half-float R, G, B without compression; pixel(x, y) gives
    linear (r, g, b), y = 0 the top row."""
    channels = b"".join(name + b"\0" + struct.pack("<iBBBBii", 1, 0, 0, 0, 0, 1, 1) for name in (b"B", b"G", b"R"))
    channels += b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join(
        [
            _attribute("channels", "chlist", channels),
            _attribute("compression", "compression", b"\0"),
            _attribute("dataWindow", "box2i", box),
            _attribute("displayWindow", "box2i", box),
            _attribute("lineOrder", "lineOrder", b"\0"),
            _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
            _attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
            _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        ]
    ) + b"\0"
    magic = struct.pack("<ii", 20000630, 2)
    line_bytes = width * 3 * 2
    start = len(magic) + len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", start + y * (8 + line_bytes)) for y in range(height))
    lines = bytearray()
    for y in range(height):
        values = [pixel(x, y) for x in range(width)]
        lines.extend(struct.pack("<ii", y, line_bytes))
        for c in (2, 1, 0):  # channels in alphabetical order: B, G, R
            lines.extend(struct.pack("<%de" % width, *(v[c] for v in values)))
    with open(path, "wb") as f:
        f.write(magic + header + offsets + bytes(lines))
