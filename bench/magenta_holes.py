#!/usr/bin/env python3
"""Holes in frames rendered with --clear 255,0,255: a magenta pixel between two terrain pixels of
its column (the sky cannot show through the ground; below a globe's lower limb, or above its
horizon, it is not enclosed and not counted). Prints per frame the hole count and the worst
column; exit 1 if any.
  bench/magenta_holes.py FRAME.png [FRAME.png ...]
Reads 8-bit RGB/RGBA PNGs with the standard library only."""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    i, idat, width, height, channels = 8, b"", 0, 0, 0
    while i < len(data):
        n = struct.unpack(">I", data[i:i + 4])[0]
        kind, body = data[i + 4:i + 8], data[i + 8:i + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            if depth != 8 or colour not in (2, 6):
                raise SystemExit(f"{path}: only 8-bit RGB or RGBA")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        i += 12 + n
    raw, stride, rows, prev, at = zlib.decompress(idat), width * channels, [], None, 0
    prev = bytearray(stride)
    for _ in range(height):
        kind, line = raw[at], bytearray(raw[at + 1:at + 1 + stride])
        at += 1 + stride
        for x in range(stride):
            a = line[x - channels] if x >= channels else 0
            b = prev[x]
            c = prev[x - channels] if x >= channels else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return width, height, channels, rows


def holes(path):
    width, height, channels, rows = read_png(path)
    total, worst = 0, (0, -1)
    for x in range(width):
        ground, count, run = False, 0, 0
        for y in range(height):
            p = rows[y][x * channels:x * channels + 3]
            magenta = p[0] == 255 and p[1] == 0 and p[2] == 255
            if not magenta:
                count += run if ground else 0  # the run above was enclosed
                ground, run = True, 0
            else:
                run += 1
        total += count
        worst = max(worst, (count, x))
    return total, worst


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    bad = 0
    for path in sys.argv[1:]:
        total, (count, x) = holes(path)
        print(f"{path}: {total} hole pixels" + (f" (worst column {x}: {count})" if total else ""))
        bad += total > 0
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
