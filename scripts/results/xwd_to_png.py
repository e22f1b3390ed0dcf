#!/usr/bin/env python3
"""Converts an X window dump (XWD, 24/32 bits per pixel, as Xvfb -fbdir writes its screen) to a
PNG, cropped to WIDTHxHEIGHT at the top-left corner: the README's picture of `host view`.

usage: xwd_to_png.py SCREEN.xwd OUT.png [WIDTH HEIGHT]
"""
import struct
import sys
import zlib


def main():
    src, dst = sys.argv[1], sys.argv[2]
    data = open(src, "rb").read()
    fields = struct.unpack(">25I", data[:100])
    header_size, _, _, depth, width, height = fields[:6]
    byte_order, bits_per_pixel, bytes_per_line = fields[7], fields[11], fields[12]
    ncolors = fields[19]
    if bits_per_pixel != 32:
        sys.exit(f"{src}: {bits_per_pixel} bits per pixel; only 32 are read")
    w = int(sys.argv[3]) if len(sys.argv) > 3 else width
    h = int(sys.argv[4]) if len(sys.argv) > 4 else height
    w, h = min(w, width), min(h, height)
    pixels = data[header_size + 12 * ncolors:]
    rows = []
    for y in range(h):
        line = pixels[y * bytes_per_line: y * bytes_per_line + 4 * w]
        row = bytearray(b"\0")
        for x in range(w):
            p = line[4 * x: 4 * x + 4]
            # LSBFirst (0): B G R X in memory.
            b, g, r = (p[0], p[1], p[2]) if byte_order == 0 else (p[3], p[2], p[1])
            row += bytes((r, g, b))
        rows.append(bytes(row))

    def chunk(kind, body):
        c = kind + body
        return struct.pack(">I", len(body)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(b"".join(rows), 9)) + chunk(b"IEND", b"")
    open(dst, "wb").write(png)
    print(f"{dst}: {w}x{h} of {width}x{height} (depth {depth})")


if __name__ == "__main__":
    main()
