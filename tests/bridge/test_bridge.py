"""Tests of the C++ bridge through its Python module `tide._tide`: prim lifetimes in any
order, errors as exceptions or problems (never aborts), render buffers mapped while a pass
runs, textures read with OpenImageIO reaching the delegate with the right values."""
import array
import gc
import math
import os
import random
import struct
import threading
import zlib

import pytest

from images import write_png, write_png_bytes
from tide import _tide


def floats(data):
    return array.array("f", data)


def make_scene(d):
    assert d.create_sprim("camera", "/Cam")
    assert d.create_bprim("renderBuffer", "/Out/color")
    d.set_array("/Out/color", "dimensions", [8, 4], 1, "i")
    assert d.create_rprim("mesh", "/M")
    d.set_array("/M", "points", floats([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]), 3, "f")
    d.set_array("/M", "faceVertexCounts", [4], 1, "i")
    d.set_array("/M", "faceVertexIndices", array.array("i", [0, 1, 2, 3]), 1, "i")


def test_prims_created_and_destroyed_in_any_order():
    rng = random.Random(7)
    d = _tide.RenderDelegate()
    kinds = d.supported_types()
    made = []
    for round_ in range(5):
        for kind, create in (("rprims", d.create_rprim), ("sprims", d.create_sprim), ("bprims", d.create_bprim)):
            for t in kinds[kind]:
                path = f"/{t}_{round_}"
                assert create(t, path)
                made.append(path)
        rng.shuffle(made)
        # Destroy about half, commit, keep going: no leak of stale prims, no crash.
        for path in made[: len(made) // 2]:
            assert d.destroy_prim(path)
            assert not d.destroy_prim(path)
        del made[: len(made) // 2]
        d.commit_resources()
        assert set(d.last_synced()) <= set(made)
    # A material destroyed before the mesh bound to it.
    assert d.create_sprim("material", "/Looks/M")
    assert d.create_rprim("sphere", "/S")
    d.set("/S", "material", ("path", "/Looks/M"))
    d.commit_resources()
    assert d.destroy_prim("/Looks/M")
    d.commit_resources()
    assert d.destroy_prim("/S")
    # Dropping the delegate with prims still alive.
    del d
    gc.collect()


def test_only_dirty_prims_resync():
    d = _tide.RenderDelegate()
    d.create_rprim("sphere", "/A")
    d.create_rprim("sphere", "/B")
    d.commit_resources()
    assert sorted(d.last_synced()) == ["/A", "/B"]
    d.set("/B", "radius", 2.0)
    d.commit_resources()
    assert d.last_synced() == ["/B"]
    d.commit_resources()
    assert d.last_synced() == []


def test_unknown_types_are_problems():
    d = _tide.RenderDelegate()
    assert d.create_rprim("teapot", "/T") is False
    assert d.create_sprim("mesh", "/WrongKind") is False
    problems = d.commit_resources()
    assert any(p[0] == "/T" and "teapot" in p[2] for p in problems)
    assert any(p[0] == "/WrongKind" for p in problems)


def test_errors_surface_as_python_exceptions():
    d = _tide.RenderDelegate()
    d.create_rprim("mesh", "/M")
    with pytest.raises(_tide.TideError):
        d.set("/missing", "radius", 1.0)
    with pytest.raises(ValueError):
        d.set_array("/M", "points", floats([1, 2]), 3, "f")
    with pytest.raises(ValueError):
        d.set_array("/M", "points", floats([1, 2, 3]), 3, "x")
    with pytest.raises(ValueError):
        d.set("/M", "orientation", ("nonsense", "x"))
    with pytest.raises(TypeError):
        d.set("/M", "points", [1.0, 2.0])
    with pytest.raises(TypeError):
        d.set_array("/M", "faceVertexIndices", floats([0.5]), 1, "i")
    with pytest.raises(ValueError):
        d.set_matrix("/M", "transform", [1.0] * 15)
    with pytest.raises(ValueError):
        d.set_primvar("/M", "st", "perVertex", floats([0, 0]), 2)
    with pytest.raises(_tide.TideError):
        d.map_buffer("/nope")
    p = d.create_render_pass()
    with pytest.raises(_tide.TideError):
        p.execute("/NoCamera", [("color", "/nope")])
    with pytest.raises(_tide.TideError):
        d.write_preview_png("/tmp/never.png", "/nope")
    # The delegate is still usable after all of that.
    d.set("/M", "doubleSided", True)
    d.commit_resources()
    assert d.last_synced() == ["/M"]


def test_bad_values_become_problems_not_errors():
    d = _tide.RenderDelegate()
    make_scene(d)
    d.set_array("/M", "faceVertexIndices", array.array("i", [0, 1, 2, 9]), 1, "i")
    problems = d.commit_resources()
    assert ("/M", "faceVertexIndices") in [(p[0], p[1]) for p in problems]



def test_a_problem_is_reported_once_until_mended_and_again_when_it_comes_back():
    d = _tide.RenderDelegate()
    make_scene(d)
    d.commit_resources()
    where = lambda problems: [(p[0], p[1]) for p in problems]
    # one from the Rust delegate (an index past the points), one from the C++ layer (a
    # buffer's format)
    bad_index = lambda: d.set_array("/M", "faceVertexIndices", array.array("i", [0, 1, 2, 9]), 1, "i")
    bad_format = lambda: d.set("/Out/color", "format", ("token", "float5"))
    bad_index()
    bad_format()
    assert sorted(where(d.commit_resources())) == [("/M", "faceVertexIndices"), ("/Out/color", "format")]
    # synced again, still wrong: not repeated
    bad_index()
    bad_format()
    d.set_array("/Out/color", "dimensions", [8, 2], 1, "i")
    assert where(d.commit_resources()) == []
    # mended: nothing; brought back: reported again
    d.set_array("/M", "faceVertexIndices", array.array("i", [0, 1, 2, 3]), 1, "i")
    d.set("/Out/color", "format", ("token", "float4"))
    assert where(d.commit_resources()) == []
    bad_index()
    bad_format()
    assert sorted(where(d.commit_resources())) == [("/M", "faceVertexIndices"), ("/Out/color", "format")]

def test_buffers_and_values_of_every_kind():
    d = _tide.RenderDelegate()
    make_scene(d)
    pts = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]
    d.set_array("/M", "points", bytes(floats(pts)), 3, "f")
    d.set_array("/M", "points", memoryview(array.array("d", pts)), 3, "f")
    d.set_array("/M", "velocities", array.array("d", [0.0] * 12), 3, "d")
    d.set_matrix("/M", "transform", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], time=0.0)
    d.set_matrix("/M", "transform", [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [2, 0, 0, 1]], time=1.0)
    d.set_primvar("/M", "st", "faceVarying", floats([0, 0, 1, 0, 1, 1, 0, 1]), 2, indices=[0, 1, 2, 3])
    d.set_primvar("/M", "displayColor", "constant", [0.5, 0.5, 0.5], 3)
    d.set("/M", "orientation", ("token", "leftHanded"))
    d.set("/M", "primId", 3)
    d.set("/M", "tide:note", "free text")
    d.set("/M", "purpose", ("token", "render"))
    d.create_sprim("renderSettings", "/Render")
    d.set("/Render", "includedPurposes", ("paths", ["default", "render"]))
    d.set("/Render", "camera", ("path", "/Cam"))
    assert d.commit_resources() == []


def test_buffers_mapped_while_a_pass_runs():
    d = _tide.RenderDelegate()
    make_scene(d)
    assert d.commit_resources() == []
    p = d.create_render_pass()
    seen = []
    stop = threading.Event()

    def mapper():
        while not stop.is_set():
            w, h, c, data = d.map_buffer("/Out/color")
            seen.append((w, h, c, len(data)))

    t = threading.Thread(target=mapper)
    t.start()
    try:
        for _ in range(5):
            p.execute("/Cam", [("color", "/Out/color")])
            assert p.wait(30.0)
            assert p.error() is None
    finally:
        stop.set()
        t.join()
    assert p.is_converged()
    assert 0.0 <= p.progress() <= 1.0
    assert seen, "the mapping thread never ran"
    for w, h, c, n in seen:
        assert (w, h) == (8, 4)
        assert n == w * h * c * 4
    w, h, c, data = d.map_buffer("/Out/color")
    assert (w, h, c) == (8, 4, 4)
    # A pass dropped while running, then its delegate: threads are joined, nothing aborts.
    p.execute("/Cam", [("color", "/Out/color")])
    p.cancel()
    del p, d
    gc.collect()


def test_dropping_a_replaced_pass_leaves_its_successors_render_running():
    # a viewport makes a new pass while a render runs (after an edit restarted it) and then
    # lets the old one go: the render it now owns goes on to converge
    d = _tide.RenderDelegate()
    make_scene(d)
    assert d.create_sprim("renderSettings", "/S")
    d.set("/S", "tide:samples", 2000)
    d.commit_resources()
    old = d.create_render_pass()
    old.execute("/Cam", [("color", "/Out/color")], "/S")
    d.set("/S", "tide:samples", 100000)        # restarts the running render (a few seconds)
    d.commit_resources()
    new = d.create_render_pass()
    new.execute("/Cam", [("color", "/Out/color")], "/S")
    del old
    gc.collect()
    assert new.wait(60) and new.is_converged(), new.error()
    # dropping the pass that runs the render does stop it
    d.set("/S", "tide:samples", 1000000)
    d.commit_resources()
    del new
    gc.collect()
    w, h, c, _ = d.map_buffer("/Out/color")
    assert (w, h, c) == (8, 4, 4)


def test_texture_read_with_oiio_reaches_the_delegate(tmp_path):
    # the file's values go as they are: each material decodes them by its own sourceColorSpace
    path = str(tmp_path / "checker.png")
    rows = [[(0, 128, 255), (64, 32, 16)], [(255, 255, 255), (1, 2, 3)]]
    write_png(path, 2, 2, rows)
    d = _tide.RenderDelegate()
    assert d.load_texture(path)
    w, h, c, data = d.texture_pixels(path)
    assert (w, h, c) == (2, 2, 3)
    got = array.array("f", data)
    want = [v / 255.0 for row in rows for px in row for v in px]
    assert all(math.isclose(a, b, abs_tol=1e-6) for a, b in zip(got, want)), (list(got), want)
    # read once: a second load of the unchanged file sends nothing new
    assert d.load_texture(path)
    assert array.array("f", d.texture_pixels(path)[3]) == got


def test_an_rgba_png_reaches_the_delegate_with_straight_alpha(tmp_path):
    # PNG stores colour and alpha apart: the colour must not come multiplied by alpha (and
    # certainly not before its sRGB decoding, which the delegate does)
    path = str(tmp_path / "rgba.png")
    write_png(path, 1, 1, [[(255, 64, 0, 128)]])
    d = _tide.RenderDelegate()
    assert d.load_texture(path)
    w, h, c, data = d.texture_pixels(path)
    assert (w, h, c) == (1, 1, 4)
    got = array.array("f", data)
    assert all(math.isclose(a, b, abs_tol=1e-6) for a, b in zip(got, [1.0, 64 / 255, 0.0, 128 / 255])), list(got)


def test_material_textures_load_on_sync_and_missing_ones_are_problems(tmp_path):
    path = str(tmp_path / "albedo.png")
    write_png(path, 1, 1, [[(255, 0, 0)]])
    d = _tide.RenderDelegate()
    assert d.create_sprim("material", "/Looks/M")
    d.set("/Looks/M", "surface", ("path", "/Looks/M/PBR"))
    d.set("/Looks/M", "/Looks/M/PBR.info:id", ("token", "UsdPreviewSurface"))
    d.set("/Looks/M", "/Looks/M/PBR.inputs:diffuseColor.connect", ("token", "/Looks/M/Tex.outputs:rgb"))
    d.set("/Looks/M", "/Looks/M/Tex.info:id", ("token", "UsdUVTexture"))
    d.set("/Looks/M", "/Looks/M/Tex.inputs:file", ("asset", path))
    d.set("/Looks/M", "/Looks/M/Tex.inputs:sourceColorSpace", ("token", "raw"))
    d.set("/Looks/M", "/Looks/M/Missing.info:id", ("token", "UsdUVTexture"))
    d.set("/Looks/M", "/Looks/M/Missing.inputs:file", ("asset", str(tmp_path / "nope.exr")))
    problems = d.commit_resources()
    assert d.texture_pixels(path)[:3] == (1, 1, 3)
    assert array.array("f", d.texture_pixels(path)[3]).tolist() == [1.0, 0.0, 0.0]
    where = [(p[0], p[1]) for p in problems]
    assert ("/Looks/M", "/Looks/M/Missing.inputs:file") in where, problems
    assert ("/Looks/M", "/Looks/M/Tex.inputs:file") not in where
    # Reported once: a second commit of the same material does not repeat it.
    d.set("/Looks/M", "/Looks/M/PBR.inputs:roughness", 0.5)
    again = d.commit_resources()
    assert ("/Looks/M", "/Looks/M/Missing.inputs:file") not in [(p[0], p[1]) for p in again]
    with pytest.raises(OSError, match="no such file"):
        d.load_texture(str(tmp_path / "nope.exr"))


# Loads the texture argv[1] (or, given argv[2], that grid of the VDB file argv[1]) into a new
# delegate and prints how far the process's peak memory
# rose above its memory before the load (KB; the peak is reset first, so a higher one from
# start-up does not hide the load's), then the error ("" if read).
# A child process's start: a delegate made, then the process's peak reset (status("VmHWM")
# - before is then what follows takes at its peak).
# a child process's memory: status("VmHWM") - before is its peak growth since reset_peak()
_STATUS = r"""
import sys
from tide import _tide

def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1])

def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")
    return status("VmRSS")
"""

_PEAK_RESET = _STATUS + r"""
d = _tide.RenderDelegate()
before = reset_peak()
"""

_MEASURED_LOAD = _PEAK_RESET + r"""
try:
    if len(sys.argv) > 2:
        assert d.load_vdb(sys.argv[1], sys.argv[2])
    else:
        d.load_texture(sys.argv[1])
    error = ""
except OSError as e:
    error = str(e)
print(status("VmHWM") - before)
print(error)
"""


def _measured_load(path, *grid):
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(_tide.__file__)))
    out = subprocess.run([sys.executable, "-c", _MEASURED_LOAD, str(path), *grid], env=env, check=True,
                         capture_output=True, text=True).stdout.splitlines()
    return int(out[0]) * 1024, (out[1] if len(out) > 1 else "")


def test_an_8_bit_texture_is_held_as_its_bytes(tmp_path):
    # 2048 x 4096 RGBA at 8 bits: 32 MB as bytes, 128 MB as floats. Held as bytes, read
    # straight into the memory the delegate keeps, the load peaks under two copies of them.
    w, h = 2048, 4096
    pixels = bytes(range(256)) * (w * h * 4 // 256)
    path = tmp_path / "big.png"
    write_png_bytes(str(path), w, h, 4, pixels)
    grown, error = _measured_load(path)
    assert error == ""
    assert grown < 2 * w * h * 4, "%d MB for a %d MB image" % (grown >> 20, (w * h * 4) >> 20)
    # and its values are the file's
    d = _tide.RenderDelegate()
    d.load_texture(str(path))
    got = array.array("f", d.texture_pixels(str(path))[3])
    for i in [0, 1, 255, 256 * 1000 + 17, len(pixels) - 1]:
        assert math.isclose(got[i], pixels[i] / 255.0, rel_tol=1e-7), i


def test_16_bit_and_half_float_textures_are_held_as_their_codes(tmp_path):
    # 2048 x 2048 RGBA: 32 MB as 16-bit codes, 64 MB as floats. Read straight into the memory
    # the delegate keeps, the load peaks under two copies of the codes (the decoder's buffers)
    import numpy as np
    import OpenEXR
    w, h = 2048, 2048
    ramp = np.arange(w * h * 4, dtype=np.int64)
    ints = (ramp * 40503 % 65536).astype(np.uint16)
    halves = (ramp % 30000).astype(np.uint16).view(np.float16)   # finite: below 0x7c00
    png, exr = tmp_path / "big16.png", tmp_path / "half.exr"
    write_png_bytes(str(png), w, h, 4, ints.astype(">u2").tobytes(), depth=16)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGBA": halves.reshape(h, w, 4)}).write(str(exr))
    for path, want in ((png, ints / 65535.0), (exr, halves.astype(np.float32))):
        grown, error = _measured_load(path)
        assert error == ""
        assert grown < 2 * w * h * 4 * 2, "%s: %d MB for %d MB of codes" % (path.name, grown >> 20,
                                                                              (w * h * 8) >> 20)
        d = _tide.RenderDelegate()
        assert d.load_texture(str(path))
        width, height, channels, data = d.texture_pixels(str(path))
        assert (width, height, channels) == (w, h, 4)
        got = np.frombuffer(array.array("f", data), dtype=np.float32)
        assert np.array_equal(got, want.astype(np.float32)), path.name


def test_a_grid_read_from_a_vdb_file_loads_that_grid_alone(tmp_path):
    # a file of a small density grid (32^3) and a large other one (256^3: 64 MB of floats);
    # reading density loads only its own voxels, well under the other grid's memory
    import numpy as np
    path = str(tmp_path / "two.vdb")
    _tide.write_vdb(path, [
        ("density", "float", (32, 32, 32), np.full(32 ** 3, 1.0, np.float32).tobytes(), 0.1, (0, 0, 0), (0, 0, 0)),
        ("big", "float", (256, 256, 256), np.full(256 ** 3, 0.5, np.float32).tobytes(), 0.1, (0, 0, 0),
         (0, 0, 0))])
    grown, error = _measured_load(path, "density")
    assert error == ""
    assert grown < 32 << 20, "%d MB to read a 32^3 grid" % (grown >> 20)
    # and the large one is read whole, its leaves dropped as the dense values pass them: under
    # one and a half times its floats (144 MB when the whole tree stayed while it was read)
    grown, error = _measured_load(path, "big")
    assert error == "" and (64 << 20) < grown < (96 << 20), "%d MB" % (grown >> 20)


def test_a_grid_read_while_its_leaves_are_dropped_keeps_every_value(tmp_path):
    # 43 x 29 x 37 voxels from (-3, 5, -11): leaves (8^3, aligned to multiples of 8) straddle
    # the box's faces; every voxel its own value, read back exactly. The grid read starts at
    # the leaf holding the box's low corner, (-8, 0, -16): zeros before the values
    import numpy as np
    nx, ny, nz = 43, 29, 37
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    ramp = (1 + i + 100 * j + 10000 * k).astype(np.float32)
    path = str(tmp_path / "ramp.vdb")
    _tide.write_vdb(path, [("density", "float", (nx, ny, nz), ramp.ravel().tobytes(), 0.1, (0, 0, 0), (-3, 5, -11))])
    d = _tide.RenderDelegate()
    assert d.load_vdb(path, "density")
    gx, gy, gz, data = d.grid_values(path, "density")
    pad = (-3 - -8, 5 - 0, -11 - -16)
    assert (gx, gy, gz) == (nx + pad[0], ny + pad[1], nz + pad[2])
    want = np.zeros((gz, gy, gx), dtype=np.float32)
    want[pad[2]:, pad[1]:, pad[0]:] = ramp
    assert np.array_equal(np.frombuffer(data, dtype=np.float32).reshape(gz, gy, gx), want)


def test_a_truncated_image_fails_with_its_reason_before_taking_the_memory_it_claims(tmp_path):
    # the header says 60000 x 60000 RGBA (14.4 GB); the file holds one row
    path = tmp_path / "truncated.png"
    write_png_bytes(str(path), 60000, 60000, 4, bytes(60000 * 4), rows=1)
    grown, error = _measured_load(path)
    assert error.startswith("rows 0 to ") and "\n" not in error, error
    assert grown < 256 << 20, "%d MB" % (grown >> 20)


def test_a_tiled_exr_with_an_offset_data_window_is_read_whole(tmp_path):
    # 1500 x 1100 RGB float (20 MB: read in more than one band of tile rows); tiles of 64 that
    # do not divide the image; the data window starts off the origin
    import numpy as np
    import OpenEXR
    w, h = 1500, 1100
    rgb = (np.arange(w * h * 3, dtype=np.float64) % 10007 / 10007).astype(np.float32).reshape(h, w, 3)
    tiles = OpenEXR.TileDescription()
    tiles.xSize, tiles.ySize, tiles.mode = 64, 64, OpenEXR.ONE_LEVEL
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.tiledimage, "tiles": tiles,
              "dataWindow": ((7, -5), (7 + w - 1, -5 + h - 1)), "displayWindow": ((0, 0), (w - 1, h - 1))}
    path = str(tmp_path / "tiled.exr")
    OpenEXR.File(header, {"RGB": rgb}).write(path)
    d = _tide.RenderDelegate()
    assert d.load_texture(path)
    width, height, channels, data = d.texture_pixels(path)
    assert (width, height, channels) == (w, h, 3)
    got = np.frombuffer(array.array("f", data), dtype=np.float32).reshape(h, w, 3)
    assert np.array_equal(got, rgb)


def test_preview_png_is_written_atomically(tmp_path):
    d = _tide.RenderDelegate()
    make_scene(d)
    d.commit_resources()
    p = d.create_render_pass()
    p.execute("/Cam", [("color", "/Out/color")])
    assert p.wait(30.0)
    out = str(tmp_path / "preview.png")
    d.write_preview_png(out, "/Out/color", "ACEScg", "Standard")
    with open(out, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    assert os.listdir(tmp_path) == ["preview.png"]
    with pytest.raises(_tide.TideError):
        d.write_preview_png(out, "/Out/color", "NoSuchSpace", "Standard")


_PREVIEW_WRITTEN = _STATUS + r"""
import array

d = _tide.RenderDelegate()
assert d.create_sprim("camera", "/Cam")
assert d.create_bprim("renderBuffer", "/Out/color")
d.set_array("/Out/color", "dimensions", [2048, 2048], 1, "i")
assert d.create_rprim("mesh", "/M")
d.set_array("/M", "points", array.array("f", [0, 0, -2, 1, 0, -2, 1, 1, -2, 0, 1, -2]), 3, "f")
d.set_array("/M", "faceVertexCounts", [4], 1, "i")
d.set_array("/M", "faceVertexIndices", array.array("i", [0, 1, 2, 3]), 1, "i")
assert d.create_sprim("renderSettings", "/S")
d.set("/S", "tide:samples", 1)
d.commit_resources()
p = d.create_render_pass()
p.execute("/Cam", [("color", "/Out/color")], "/S")
assert p.wait(120.0)
before = reset_peak()
d.write_preview_png(sys.argv[1], "/Out/color")
print(status("VmHWM") - before)
"""


def test_the_preview_is_written_from_the_buffer_without_copies(tmp_path):
    # a 2048 x 2048 RGBA float colour buffer (64 MiB): the preview takes the buffer's own
    # storage once (the bridge's copy of the pixels, filled in place) and writes from it
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(_tide.__file__)))
    out = subprocess.run([sys.executable, "-c", _PREVIEW_WRITTEN, str(tmp_path / "p.png")], env=env,
                         check=True, capture_output=True, text=True).stdout.splitlines()
    grown = int(out[-1]) * 1024
    buffer = 2048 * 2048 * 4 * 4
    assert grown < 1.5 * buffer, "%d MiB to preview a %d MiB buffer" % (grown >> 20, buffer >> 20)
    assert os.path.getsize(tmp_path / "p.png") > 0


_BUFFERS_SYNCED = _PEAK_RESET + r"""
for i in range(8):
    path = "/Out/aov%d" % i
    assert d.create_bprim("renderBuffer", path)
    d.set_array(path, "dimensions", [4096, 4096], 1, "i")
assert d.commit_resources() == []
print(status("VmHWM") - before)
w, h, c, data = d.map_buffer("/Out/aov3")
print(w, h, c, len(data), max(data[:4096 * 16]), max(data[-4096 * 16:]))
"""


def test_a_render_buffer_takes_its_memory_when_first_read():
    # eight 4096 x 4096 RGBA float buffers (2 GiB) synced and never read hold no pixels; the one
    # mapped reads as its dimensions' zeros
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(_tide.__file__)))
    out = subprocess.run([sys.executable, "-c", _BUFFERS_SYNCED], env=env, check=True,
                         capture_output=True, text=True).stdout.splitlines()
    grown = int(out[0]) * 1024
    assert grown < 64 << 20, "%d MB for eight buffers never read" % (grown >> 20)
    w, h, c, n, first, last = out[1].split()
    assert (int(w), int(h), int(c), int(n)) == (4096, 4096, 4, 4096 * 4096 * 4 * 4)
    assert float(first) == 0.0 and float(last) == 0.0


def test_a_pass_renders_the_prims_its_render_tags_name():
    # two unit spheres side by side in front of the camera, under a white dome: the left one
    # tagged geometry, the right one proxy
    d = _tide.RenderDelegate()
    assert d.create_sprim("camera", "/Cam")
    d.set("/Cam", "focalLength", 20.0)
    d.set("/Cam", "horizontalAperture", 40.0)
    d.set("/Cam", "verticalAperture", 20.0)
    assert d.create_sprim("domeLight", "/Dome")
    assert d.create_sprim("renderSettings", "/S")
    d.set("/S", "tide:samples", 4)
    d.set("/S", "tide:integrator", ("token", "path"))
    assert d.create_bprim("renderBuffer", "/Out/color")
    d.set_array("/Out/color", "dimensions", array.array("i", [16, 8]), 1, "i")
    for path, x, tag in (("/Left", -1.5, "geometry"), ("/Right", 1.5, "proxy")):
        assert d.create_rprim("sphere", path)
        d.set_matrix(path, "transform", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, -5, 1])
        d.set(path, "renderTag", ("token", tag))
    assert d.commit_resources() == []
    p = d.create_render_pass()

    def centres(tags):
        p.execute("/Cam", [("color", "/Out/color")], "/S", render_tags=tags)
        assert p.wait(60.0) and p.error() is None
        w, h, c, data = d.map_buffer("/Out/color")
        px = struct.unpack("%df" % (len(data) // 4), data)
        # the red of the pixels at the spheres' centres (row 4; columns 4 and 11), and of the
        # dome alone (a corner)
        return [px[(4 * w + col) * c] for col in (4, 11)], px[0]

    # a sphere reads well under the dome (about 0.2 against 0.9; the dome's own pixels vary by a
    # few hundredths with their wavelength samples)
    def shown(tags):
        values, dome = centres(tags)
        return [v < dome - 0.4 for v in values]

    assert shown(None) == [True, True]
    assert shown(["geometry"]) == [True, False]
    assert shown(["proxy", "render"]) == [False, True]
    assert shown(["render"]) == [False, False]
    assert shown([]) == [True, True]
