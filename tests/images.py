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


def read_png(path):
    """(width, height, channels, bytes) of an 8-bit RGB or RGBA PNG (non-interlaced), its rows
    unfiltered (PNG's five filter types)."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    at, idat = 8, []
    while at < len(data):
        n, tag = struct.unpack(">I4s", data[at:at + 8])
        body = data[at + 8:at + 8 + n]
        if tag == b"IHDR":
            width, height, depth, kind, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and kind in (2, 6) and interlace == 0, "only 8-bit RGB/RGBA, not interlaced"
        elif tag == b"IDAT":
            idat.append(body)
        at += 12 + n
    channels = 4 if kind == 6 else 3
    raw = zlib.decompress(b"".join(idat))
    stride = width * channels
    out = bytearray()
    prev = bytearray(stride)
    for y in range(height):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        out += line
        prev = line
    return width, height, channels, bytes(out)
