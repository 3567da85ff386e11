"""A recording stand-in for the bridge module `tide._tide`.

Same Python API as the real module (RenderDelegate, render passes, buffers, EXR/PNG output),
but it renders nothing: it records every call so the scene reader can be tested quickly and
independently of the renderer. Buffers read back as zeros; a pass converges at once.
"""
import array
import os
import struct
import zlib

RPRIMS = {"mesh", "basisCurves", "points", "sphere", "cube", "cylinder", "cone", "capsule", "plane",
          "tideOcean", "volume"}
SPRIMS = {"camera", "material", "distantLight", "domeLight", "sphereLight", "rectLight",
          "diskLight", "cylinderLight", "portalLight", "renderSettings"}
BPRIMS = {"renderBuffer"}
_CHANNELS = {"float": 1, "float2": 2, "float3": 3, "float4": 4}


def _as_list(buffer, kind):
    if isinstance(buffer, (bytes, bytearray, memoryview)):
        return list(array.array(kind, bytes(buffer)))
    try:
        import numpy as np
        if isinstance(buffer, np.ndarray):
            return buffer.reshape(-1).tolist()
    except ImportError:
        pass
    return list(buffer)


class RenderDelegate:
    def __init__(self):
        self.prims = {}          # path -> type
        self.values = {}         # path -> {key: {time: value}}
        self.primvars = {}       # path -> {name: (interpolation, data, tuple, indices)}
        self.textures = set()    # asset paths loaded
        self.calls = []          # (method, path, key) in call order
        self._dirty = set()
        self._synced = []
        self._problems = []
        self._passes = []
        self.commits = 0

    # -- prims ----------------------------------------------------------------------------
    def _create(self, kind, allowed, type_name, path):
        self.calls.append(("create_" + kind, path, type_name))
        if type_name not in allowed:
            self._problems.append((path, "type", "unknown %s type '%s'" % (kind, type_name)))
            return False
        self.prims[path] = type_name
        self.values.setdefault(path, {})
        self._dirty.add(path)
        return True

    def create_rprim(self, type_name, path):
        return self._create("rprim", RPRIMS, type_name, path)

    def create_sprim(self, type_name, path):
        return self._create("sprim", SPRIMS, type_name, path)

    def create_bprim(self, type_name, path):
        return self._create("bprim", BPRIMS, type_name, path)

    def destroy_prim(self, path):
        self.calls.append(("destroy_prim", path, None))
        self.prims.pop(path, None)
        self.values.pop(path, None)
        self.primvars.pop(path, None)
        self._dirty.add(path)

    # -- values ---------------------------------------------------------------------------
    def _store(self, path, key, value, time):
        if path not in self.prims:
            raise KeyError("no prim %s" % path)
        self.calls.append(("set", path, key))
        samples = self.values[path].setdefault(key, {})
        if time is None:
            samples.clear()
        samples[time] = value
        self._dirty.add(path)

    def set(self, path, key, value, time=None):
        if isinstance(value, tuple):
            tag = value[0]
            if tag not in ("token", "asset", "path", "paths", "string"):
                raise TypeError("unknown value tag %r" % (tag,))
        elif not isinstance(value, (bool, int, float, str)):
            raise TypeError("unsupported value for %s.%s: %r" % (path, key, value))
        self._store(path, key, value, time)

    def set_array(self, path, key, buffer, tuple_size, kind, time=None):
        if kind not in ("f", "d", "i"):
            raise TypeError("kind must be 'f', 'd' or 'i'")
        self._store(path, key, (kind, int(tuple_size), _as_list(buffer, kind)), time)

    def set_matrix(self, path, key, m, time=None):
        m = [float(x) for x in m]
        if len(m) != 16:
            raise ValueError("a matrix has 16 elements")
        self._store(path, key, ("matrix", m), time)

    def set_primvar(self, path, name, interpolation, buffer, tuple_size, indices=None):
        if path not in self.prims:
            raise KeyError("no prim %s" % path)
        self.calls.append(("set_primvar", path, name))
        data = _as_list(buffer, "f")
        idx = None if indices is None else _as_list(indices, "i")
        self.primvars.setdefault(path, {})[name] = (interpolation, data, int(tuple_size), idx)
        self._dirty.add(path)

    def load_texture(self, asset_path):
        self.calls.append(("load_texture", asset_path))
        if not asset_path or not os.path.isfile(asset_path):
            raise OSError("no such file")
        self.textures.add(asset_path)
        return True

    def load_vdb(self, asset_path, field_name, field_index=0, reload=False):
        self.calls.append(("load_vdb", asset_path, field_name, field_index) + (("reload",) if reload else ()))
        return bool(asset_path) and os.path.isfile(asset_path)

    # -- sync -----------------------------------------------------------------------------
    def check_render(self):
        return self.commit_resources()

    def commit_resources(self):
        self.commits += 1
        self._synced = sorted(self._dirty)
        changed = bool(self._dirty)
        self._dirty = set()
        problems, self._problems = self._problems, []
        if changed:
            for p in self._passes:
                if p.running:
                    p.restarts += 1
        return problems

    def last_synced(self):
        return list(self._synced)

    # -- helpers for tests ----------------------------------------------------------------
    def value(self, path, key, time=None):
        samples = self.values.get(path, {}).get(key)
        if not samples:
            return None
        if time in samples:
            return samples[time]
        return samples[sorted(samples, key=lambda t: (t is not None, t or 0))[0]]

    def samples(self, path, key):
        return dict(self.values.get(path, {}).get(key, {}))

    def of_type(self, type_name):
        return sorted(p for p, t in self.prims.items() if t == type_name)

    # -- rendering ------------------------------------------------------------------------
    def create_render_pass(self):
        p = RenderPass(self)
        self._passes.append(p)
        return p

    def map_buffer(self, path):
        vals = self.values.get(path)
        if vals is None or self.prims.get(path) != "renderBuffer":
            raise KeyError("no render buffer %s" % path)
        w, h = self.value(path, "dimensions")[2]
        fmt = self.value(path, "format") or ("token", "float4")
        c = _CHANNELS.get(fmt[1], 4)
        return (w, h, c, bytes(4 * w * h * c))

    def write_exr(self, path, layers, header):
        """layers: [(name, aov sourceName[, dataType])] of the current render, as the real
        module (this stand-in writes floats whatever the dataType)."""
        if not layers:
            raise ValueError("no channels to write")
        bound = {}
        for p in self._passes:
            for _, bindings, _ in p.executed[-1:]:
                bound.update(dict(bindings))
        buffers = []
        for name, aov, *_ in layers:
            if aov not in bound:
                raise RuntimeError("%s: layer '%s': AOV '%s' was not rendered" % (path, name, aov))
            buffers.append((name, bound[aov]))
        w, h, _, _ = self.map_buffer(buffers[0][1])
        tmp = path + ".tmp%d" % os.getpid()
        try:
            _write_exr_zeros(tmp, w, h, buffers, self, header)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)

    def write_preview_png(self, path, buffer_path, color_space="lin_rec709", view="Standard"):
        w, h, _, _ = self.map_buffer(buffer_path)
        row = b"\x00" + bytes(3 * w)
        raw = zlib.compress(row * h)

        def chunk(tag, data):
            return (struct.pack(">I", len(data)) + tag + data
                    + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

        png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
               + chunk(b"IDAT", raw) + chunk(b"IEND", b""))
        tmp = path + ".tmp%d" % os.getpid()
        with open(tmp, "wb") as f:
            f.write(png)
        os.replace(tmp, path)


def _channel_names(name, count):
    if name == "color":
        return ["R", "G", "B", "A"][:count]
    if count == 1:
        return [name + ".Z"]
    return [name + "." + c for c in "RGBA"[:count]]


def _write_exr_zeros(tmp, w, h, channels, delegate, header):
    import numpy as np
    import OpenEXR

    chans = {}
    for name, buf in channels:
        _, _, c, _ = delegate.map_buffer(buf)
        for ch in _channel_names(name, c):
            chans[ch] = np.zeros((h, w), dtype=np.float32)
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for k, v in header.items():
        hdr[k] = str(v)
    with OpenEXR.File(hdr, chans) as f:
        f.write(tmp)


class RenderPass:
    def __init__(self, delegate):
        self.delegate = delegate
        self.executed = []
        self.running = False
        self.restarts = 0
        self.cancelled = False

    def execute(self, camera_path, bindings, settings_path):
        for _, buf in bindings:
            if self.delegate.prims.get(buf) != "renderBuffer":
                raise KeyError("no render buffer %s" % buf)
        self.executed.append((camera_path, list(bindings), settings_path))
        self.running = True

    def is_converged(self):
        return self.running

    def progress(self):
        return 1.0 if self.running else 0.0

    def summary(self):
        return {}

    def wait(self, timeout_s=None):
        return self.running

    def cancel(self):
        self.cancelled = True
        self.running = False
