"""Reads the string attributes of an OpenEXR file's (first) header with the standard library
only: the renderer records what it did there (`tide:spp`, `tide:integrator`, ...)."""
import struct

MAGIC = b"\x76\x2f\x31\x01"


def read_header(path):
    """{name: value} of the first part's attributes; string values decoded, others as bytes."""
    out = {}
    with open(path, "rb") as f:
        if f.read(4) != MAGIC:
            raise ValueError("%s: not an OpenEXR file" % path)
        f.read(4)                                    # version and flags

        def cstr():
            b = bytearray()
            while True:
                c = f.read(1)
                if not c:
                    raise ValueError("%s: truncated header" % path)
                if c == b"\x00":
                    return bytes(b)
                b += c
                if len(b) > 1024:
                    raise ValueError("%s: malformed header" % path)

        while True:
            name = cstr()
            if not name:
                return out
            kind = cstr()
            raw = f.read(4)
            if len(raw) != 4:
                raise ValueError("%s: truncated header" % path)
            size = struct.unpack("<i", raw)[0]
            if size < 0:
                raise ValueError("%s: malformed attribute %r" % (path, name))
            value = f.read(size)
            if len(value) != size:
                raise ValueError("%s: truncated attribute %r" % (path, name))
            key = name.decode("utf-8", "replace")
            out[key] = value.decode("utf-8", "replace") if kind == b"string" else value
