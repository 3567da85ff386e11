"""Memory and time of 8-bit textures: COUNT (default 8) 4096x4096 RGBA PNGs (written to a temp
dir), each the diffuse colour of its own sphere, read through the usd-core reader and rendered
at 64x36, 1 spp. Prints the load (reader + commit) and first-pass times and the process's peak
RSS against the bytes the files' pixels hold. With --half the textures are half-float EXRs.

    .venv/bin/python bench/front_door_textures.py [--count N] [--half] [REPO_ROOT]

REPO_ROOT (default: this checkout) picks the `tide` package whose module is measured, so an
earlier build can be measured by the same script.
"""
import argparse
import os
import struct
import sys
import tempfile
import time

from measure import THIS_CHECKOUT, load_timed, peak_mib, tide_from
import zlib

ap = argparse.ArgumentParser()
ap.add_argument("--count", type=int, default=8)
ap.add_argument("--half", action="store_true", help="half-float EXRs instead of 8-bit PNGs")
ap.add_argument("root", nargs="?", default=THIS_CHECKOUT)
args = ap.parse_args()
usd_reader, module = tide_from(args.root)
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade

W = H = 4096


def png(path, k):
    """An RGBA PNG of horizontal bands whose colour depends on k (compresses, unlike noise)."""
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    z = zlib.compressobj(1)
    rows = [z.compress(b"\x00" + bytes(((y + 37 * k) & 255, (3 * y) & 255, k * 20 & 255, 255)) * W) for y in range(H)]
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 6, 0, 0, 0)))
        f.write(chunk(b"IDAT", b"".join(rows) + z.flush()) + chunk(b"IEND", b""))


def exr(path, k):
    """A half-float RGBA EXR of the same bands as png()."""
    import numpy as np
    import OpenEXR
    y = np.arange(H, dtype=np.float32)[:, None]
    bands = np.stack([((y + 37 * k) % 256) / 255, (3 * y % 256) / 255, np.full_like(y, k * 20 % 256 / 255),
                      np.ones_like(y)], axis=-1)
    rgba = np.broadcast_to(bands, (H, W, 4)).astype(np.float16)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGBA": rgba}).write(path)


tmp = tempfile.mkdtemp()
s = Usd.Stage.CreateInMemory()
UsdGeom.SetStageUpAxis(s, "Y")
cam = UsdGeom.Camera.Define(s, "/Cam")
cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 3 * args.count))
UsdLux.DomeLight.Define(s, "/Dome")
for k in range(args.count):
    path = os.path.join(tmp, "t%d.%s" % (k, "exr" if args.half else "png"))
    (exr if args.half else png)(path, k)
    mat = UsdShade.Material.Define(s, "/M%d" % k)
    pbr = UsdShade.Shader.Define(s, "/M%d/PBR" % k)
    pbr.CreateIdAttr("UsdPreviewSurface")
    tex = UsdShade.Shader.Define(s, "/M%d/Tex" % k)
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(path)
    pbr.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tex.ConnectableAPI(), "rgb")
    mat.CreateSurfaceOutput().ConnectToSource(pbr.ConnectableAPI(), "surface")
    sphere = UsdGeom.Sphere.Define(s, "/S%d" % k)
    sphere.AddTranslateOp().Set(Gf.Vec3d(2.5 * (k - (args.count - 1) / 2), 0, 0))
    UsdShade.MaterialBindingAPI.Apply(sphere.GetPrim()).Bind(mat)
st = UsdRender.Settings.Define(s, "/Render/S")
st.CreateResolutionAttr(Gf.Vec2i(64, 36))
st.CreateCameraRel().SetTargets(["/Cam"])
st.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(1)
st.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")

r, read_s, commit_s, problems = load_timed(usd_reader, module, s)
t1 = time.perf_counter()
rp = r.render_pass()
while not rp.is_converged():
    rp.wait(5.0)
t2 = time.perf_counter()


size = 2 if args.half else 1
print("%d 4096x4096 RGBA %s textures (%d MiB of pixels): load %.2f s, first pass %.2f s, peak %.0f MiB%s"
      % (args.count, "half-float" if args.half else "8-bit", args.count * W * H * 4 * size >> 20, read_s + commit_s, t2 - t1, peak_mib(), "; problems: %s" % problems if problems else ""))
