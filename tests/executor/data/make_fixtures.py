#!/usr/bin/env python3
"""Writes the executor tests' fixtures: hall.png (a 12 m x 8 m walled hall at 5 cm per cell,
for map_server's hall.yaml) and content.png (a 64x48 test card). Standard library only."""
import struct
import zlib


def write_png(path, width, height, rows, colour):
    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    header = struct.pack(">IIBBBBB", width, height, 8, 2 if colour else 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9))
                + chunk(b"IEND", b""))


def hall():
    width, height, wall = 240, 160, 3
    rows = []
    for v in range(height):
        rows.append([0 if (u < wall or u >= width - wall or v < wall or v >= height - wall) else 254
                     for u in range(width)])
    write_png("hall.png", width, height, rows, colour=False)


def content():
    width, height = 64, 48
    rows = []
    for v in range(height):
        row = []
        for u in range(width):
            row += [(u * 4) % 256, (v * 5) % 256, 200 if (u // 8 + v // 8) % 2 else 40]
        rows.append(row)
    write_png("content.png", width, height, rows, colour=True)


if __name__ == "__main__":
    hall()
    content()
