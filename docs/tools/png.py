#!/usr/bin/env python3
"""Writes the documentation's pictures as PNG with nothing but numpy and zlib.

  python docs/tools/png.py pgm IN.pgm OUT.png [SCALE]      # a grey map (e.g. the guiding table)
  python docs/tools/png.py exr IN.exr OUT.png [EXPOSURE]   # an EXR's colour, sRGB-encoded
"""
import struct
import sys
import zlib

import numpy as np


def write_png(path, img):
    """img: H x W x 3 (or H x W) uint8."""
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    h, w, _ = img.shape
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def srgb(x):
    x = np.clip(x, 0.0, None)
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 1e-12), 1 / 2.4) - 0.055)
    return (np.clip(y, 0, 1) * 255 + 0.5).astype(np.uint8)


def read_pgm(path):
    tok = open(path).read().split()
    assert tok[0] == "P2"
    w, h = int(tok[1]), int(tok[2])
    return np.array(tok[4:4 + w * h], dtype=np.uint8).reshape(h, w)


def read_exr_rgb(path):
    import OpenEXR
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGBA" in ch:
            return np.asarray(ch["RGBA"].pixels)[..., :3]
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels)
        return np.stack([np.asarray(ch[c].pixels) for c in "RGB"], axis=-1)


if __name__ == "__main__":
    kind, src, dst = sys.argv[1:4]
    if kind == "pgm":
        s = int(sys.argv[4]) if len(sys.argv) > 4 else 4
        img = read_pgm(src)
        write_png(dst, np.kron(img, np.ones((s, s), dtype=np.uint8)))
    else:
        e = float(sys.argv[4]) if len(sys.argv) > 4 else 1.0
        write_png(dst, srgb(read_exr_rgb(src) * e))
