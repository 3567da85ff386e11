"""Image files for tests, written without an imaging library."""
import struct
import zlib


def write_png(path, width, height, rows):
    """A minimal 8-bit PNG writer (rows: lists of (r, g, b) byte triples, or of (r, g, b, a)
    quadruples for RGBA with straight alpha, as PNG stores it)."""
    channels = len(rows[0][0])
    write_png_bytes(path, width, height, channels, b"".join(bytes(c for px in row for c in px) for row in rows))


def write_png_bytes(path, width, height, channels, pixels, rows=None, depth=8):
    """An 8-bit (or, with `depth` 16, 16-bit) PNG of `channels` (3: RGB, 4: RGBA) whose header
    says `width` × `height`, from `pixels` (bytes, rows from the top; 16-bit samples big-endian,
    as PNG stores them); only its first `rows` rows are stored if given (a truncated file)."""
    stride = width * channels * depth // 8
    stored = height if rows is None else rows
    z = zlib.compressobj(6)
    data = [z.compress(b"\x00" + pixels[y * stride:(y + 1) * stride]) for y in range(stored)]
    data.append(z.flush())

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, 6 if channels == 4 else 2,
                                           0, 0, 0)))
        f.write(chunk(b"IDAT", b"".join(data)))
        f.write(chunk(b"IEND", b""))
