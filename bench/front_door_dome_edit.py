"""Edits under a large dome texture: a 4096x2048 RGB Radiance HDR (written to a temp dir) lights
a quad; the quad is moved five times, each move followed by reader.update() and the restarted
64x36, 1-spp pass. Prints the medians and the process's peak RSS.

    .venv/bin/python bench/front_door_dome_edit.py [REPO_ROOT]

REPO_ROOT (default: this checkout) picks the `tide` package whose module is measured, so an
earlier build can be measured by the same script.
"""
import os
import statistics
import sys
import tempfile
import time

root = sys.argv[1] if len(sys.argv) > 1 else os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(root, "cpp-bridge", "python"))
import numpy as np
from tide import env
env.prepare()
from tide import usd_reader
module = env.load_module()
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender
w, h = 4096, 2048
px = np.random.default_rng(1).uniform(0.2, 1.0, (h, w, 3)).astype(np.float32)
sky = os.path.join(tempfile.mkdtemp(), "sky.hdr")
# flat (not run-length encoded) RGBE scanlines: a shared exponent per pixel
e = np.ceil(np.log2(px.max(axis=2)))
rgbe = np.concatenate([np.floor(px / np.exp2(e)[..., None] * 256.0), (e + 128.0)[..., None]], axis=2)
with open(sky, "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w))
    f.write(rgbe.clip(0, 255).astype(np.uint8).tobytes())
s = Usd.Stage.CreateInMemory(); UsdGeom.SetStageUpAxis(s, 'Y')
cam = UsdGeom.Camera.Define(s, '/Cam'); cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 3))
d = UsdLux.DomeLight.Define(s, '/Dome'); d.CreateTextureFileAttr(sky)
m = UsdGeom.Mesh.Define(s, '/Quad'); m.CreatePointsAttr([(-1,-1,0),(1,-1,0),(1,1,0),(-1,1,0)]); m.CreateFaceVertexCountsAttr([4]); m.CreateFaceVertexIndicesAttr([0,1,2,3])
op = m.AddTranslateOp(); op.Set(Gf.Vec3d(0, 0, 0))
st = UsdRender.Settings.Define(s, '/Render/S'); st.CreateResolutionAttr(Gf.Vec2i(64, 36)); st.CreateCameraRel().SetTargets(['/Cam'])
st.GetPrim().CreateAttribute('tide:samples', Sdf.ValueTypeNames.Int).Set(1)
st.GetPrim().CreateAttribute('tide:integrator', Sdf.ValueTypeNames.Token).Set('path')
dl = module.RenderDelegate(); r = usd_reader.Reader(s, dl, usd_reader.Options()); r.populate(); r.commit(); rp = r.render_pass()
def wait():
    while not rp.is_converged():
        rp.wait(5.0)
wait()
ups, passes = [], []
for k in range(5):
    op.Set(Gf.Vec3d(0.01 * (k + 1), 0, 0))
    t = time.perf_counter(); r.update(); t1 = time.perf_counter(); wait(); t2 = time.perf_counter()
    ups.append(t1 - t); passes.append(t2 - t1)
def hwm():
    for l in open('/proc/self/status'):
        if l.startswith('VmHWM'): return int(l.split()[1]) / 1024
print('move a prim under a 4096x2048 RGB dome: update %.4f s, pass %.4f s (medians of 5), peak %.0f MiB' % (statistics.median(ups), statistics.median(passes), hwm()))
