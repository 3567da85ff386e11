"""Fixtures for the USD suites: stage authoring helpers, the recording fake delegate and,
for rendering tests, the real module (skipped with the reason when it is not usable yet)."""
import math
import os

import numpy as np
import OpenEXR
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade

from tide import env, fake, usd_reader

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


@pytest.fixture
def stage():
    s = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    return s


@pytest.fixture
def delegate():
    return fake.RenderDelegate()


def camera(stage, path="/Cam", pos=(0, 0, 0), focal=50.0, aperture=(36.0, 36.0), **attrs):
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateFocalLengthAttr(focal)
    cam.CreateHorizontalApertureAttr(aperture[0])
    cam.CreateVerticalApertureAttr(aperture[1])
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 10000))
    if pos != (0, 0, 0):
        cam.AddTranslateOp().Set(Gf.Vec3d(*pos))
    for k, v in attrs.items():
        cam.GetPrim().GetAttribute(k.replace("__", ":")).Set(v)
    return cam


def settings(stage, path="/Render/Settings", cam="/Cam", res=(32, 32), vars_=("color",),
             product="out.exr", **tide):
    s = UsdRender.Settings.Define(stage, path)
    s.CreateResolutionAttr(Gf.Vec2i(*res))
    s.CreateCameraRel().SetTargets([cam])
    prod = UsdRender.Product.Define(stage, path + "_Product")
    prod.CreateProductNameAttr(product)
    targets = []
    for i, v in enumerate(vars_):
        var = UsdRender.Var.Define(stage, "%s_Var%d" % (path, i))
        var.CreateSourceNameAttr(v)
        targets.append(var.GetPath())
    prod.CreateOrderedVarsRel().SetTargets(targets)
    s.CreateProductsRel().SetTargets([prod.GetPath()])
    for k, v in tide.items():
        name = "tide:" + k.replace("__", ":")
        tn = {int: Sdf.ValueTypeNames.Int, float: Sdf.ValueTypeNames.Float,
              str: Sdf.ValueTypeNames.Token}[type(v)]
        s.GetPrim().CreateAttribute(name, tn).Set(v)
    stage.SetMetadata("renderSettingsPrimPath", path)
    return s


def preview_material(stage, path, color=(0.5, 0.5, 0.5), **inputs):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    for k, v in inputs.items():
        tn = Sdf.ValueTypeNames.Float if isinstance(v, float) else Sdf.ValueTypeNames.Color3f
        sh.CreateInput(k, tn).Set(v)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def lambert_material(stage, path, color):
    """A purely Lambertian UsdPreviewSurface: specular workflow with black specular."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/S")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    sh.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    sh.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def exact_lambert_material(stage, path, albedo):
    """An exactly Lambertian material of grey `albedo`: MaterialX standard_surface with no
    specular layer (a UsdPreviewSurface's diffuse lies under a Fresnel layer that darkens it in
    grazing light, even with a black specular colour)."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + "/SR")
    sh.CreateIdAttr("ND_standard_surface_surfaceshader")
    sh.CreateInput("base", Sdf.ValueTypeNames.Float).Set(1.0)
    sh.CreateInput("base_color", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(albedo, albedo, albedo))
    sh.CreateInput("specular", Sdf.ValueTypeNames.Float).Set(0.0)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(sh.CreateOutput("out", Sdf.ValueTypeNames.Token))
    return mat


def bind(prim, mat, purpose=None):
    api = UsdShade.MaterialBindingAPI.Apply(prim)
    if purpose:
        api.Bind(mat, UsdShade.Tokens.fallbackStrength, purpose)
    else:
        api.Bind(mat)


def load(stage, delegate, **opts):
    reader = usd_reader.Reader(stage, delegate, usd_reader.Options(**opts))
    problems = reader.load()
    return reader, problems


def matrix(value):
    """A fake-recorded matrix value as a 4x4 numpy array."""
    assert value[0] == "matrix"
    return np.asarray(value[1], dtype=np.float64).reshape(4, 4)


def floats(value):
    kind, tsize, data = value
    a = np.asarray(data, dtype=np.float64)
    return a.reshape(-1, tsize) if tsize > 1 else a


# -- the real module --------------------------------------------------------------------------
_RENDERER = {}


def _probe():
    """None when the module renders, else why not (used as the skip reason)."""
    try:
        module = env.load_module(fake=False)
    except RuntimeError as e:
        return "needs the bridge module: %s" % e
    try:
        s = Usd.Stage.CreateInMemory()
        camera(s)
        dome = UsdLux.DomeLight.Define(s, "/Dome")
        dome.CreateColorAttr(Gf.Vec3f(0.25, 0.5, 0.75))
        settings(s, res=(4, 4), samples=4)
        d = module.RenderDelegate()
        r = usd_reader.Reader(s, d)
        r.load()
        rp = r.render_pass()
        for _ in range(200):
            if rp.is_converged():
                break
            rp.wait(0.1)
        w, h, c, data = d.map_buffer(r.bindings()[0][1])
        px = np.frombuffer(data, dtype=np.float32).reshape(h, w, c)
        if not np.allclose(px[..., :3].mean(axis=(0, 1)), [0.25, 0.5, 0.75], rtol=0.1):
            return ("the core renderer does not render yet: a 4x4 dome-only probe gave %s "
                    "instead of the dome colour (0.25, 0.5, 0.75)"
                    % np.round(px[..., :3].mean(axis=(0, 1)), 3).tolist())
    except Exception as e:  # noqa: BLE001 - any failure means "cannot render yet"
        return "the core renderer cannot render yet (%s: %s)" % (type(e).__name__, e)
    return None


@pytest.fixture
def renderer():
    if "why" not in _RENDERER:
        _RENDERER["why"] = _probe()
    if _RENDERER["why"]:
        pytest.skip(_RENDERER["why"])
    return env.load_module(fake=False)


def render(module, stage, problems=None, **opts):
    """Renders `stage` with the real module; returns {sourceName: HxWxC array}. The problems
    the load reports are appended to `problems` when it is given."""
    d = module.RenderDelegate()
    r = usd_reader.Reader(stage, d, usd_reader.Options(**opts))
    found = r.load()
    if problems is not None:
        problems.extend(found)
    return converged_images(r, d, r.render_pass(), 60)


def converged_images(reader, delegate, rp, seconds):
    """Waits up to `seconds` for the pass `rp` to converge; returns {sourceName: HxWxC array}
    of the reader's bindings (copies: the delegate may render into its buffers again)."""
    for _ in range(int(seconds * 10)):
        if rp.is_converged():
            break
        rp.wait(0.1)
    assert rp.is_converged(), "the render did not converge in %g s" % seconds
    out = {}
    for aov, buf in reader.bindings():
        w, h, c, data = delegate.map_buffer(buf)
        out[aov] = np.frombuffer(data, dtype=np.float32).reshape(h, w, c).copy()
    return out


def linked_assets(where):
    """Links the example stages and the test data (and their assets) into `where`, where a
    rewritten copy of a stage then finds its relative asset paths."""
    for d in (os.path.join(os.path.dirname(__file__), "data"), os.path.join(ROOT, "docs", "stages")):
        for f in os.listdir(d):
            if not os.path.exists(os.path.join(where, f)):
                os.symlink(os.path.join(d, f), os.path.join(where, f))


def fresnel(mu, eta):
    """Unpolarised Fresnel reflectance for light arriving at cosine mu from the side of index 1
    onto index eta (eta < 1: from the denser side; 1 beyond the critical angle)."""
    s2 = (1 - mu * mu) / (eta * eta)
    if s2 >= 1:
        return 1.0
    ct = math.sqrt(1 - s2)
    rs = (mu - eta * ct) / (mu + eta * ct)
    rp = (eta * mu - ct) / (eta * mu + ct)
    return 0.5 * (rs * rs + rp * rp)


def diffuse_reflectances(n, steps=4000):
    """(r_e, r_i): a smooth interface's reflectance for diffuse light arriving from outside
    (2 int F mu dmu, midpoint rule) and from the side of index n (1 - (1 - r_e)/n^2)."""
    r_e = sum(2 * fresnel(mu, n) * mu / steps for mu in ((k + 0.5) / steps for k in range(steps)))
    return r_e, 1 - (1 - r_e) / (n * n)


def darkness(img):
    """1 - luminance of a render against a white dome: the fraction of a pixel covered."""
    rgb = img[..., :3].astype(np.float64)
    return 1.0 - (0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2])



def fwhm(row):
    """Full width at half maximum (pixels) of a profile along a row, with sub-pixel crossings
    by linear interpolation on both sides."""
    half = row.max() / 2
    above = np.nonzero(row > half)[0]
    lo, hi = above[0], above[-1]
    left = lo - 1 + (half - row[lo - 1]) / (row[lo] - row[lo - 1])
    right = hi + (row[hi] - half) / (row[hi] - row[hi + 1])
    return right - left


# -- a top view of panels and balls under a white sky -------------------------------------------
RES = 32
HALF = 2.0  # the panels span [-HALF, HALF] in x and z


def top_camera(stage):
    """An orthographic camera looking down -Y at the 2 HALF square: column i sees x at
    -HALF + (i + 0.5) 2 HALF / RES, row j sees z at -HALF + (j + 0.5) 2 HALF / RES."""
    cam = camera(stage, pos=(0, 5, 0), aperture=(20 * HALF, 20 * HALF), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)


def panel(stage, path, columns=2, st=False):
    """`columns` quads side by side along x, facing up (+Y), covering the square; with `st`,
    texture coordinates u along x and v along z, (0, 0) to (1, 1) over the square."""
    m = UsdGeom.Mesh.Define(stage, path)
    xs = np.linspace(-HALF, HALF, columns + 1)
    pts = [(x, 0, z) for x in xs for z in (-HALF, HALF)]
    m.CreatePointsAttr(pts)
    if st:
        UsdGeom.PrimvarsAPI(m.GetPrim()).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
            [((x + HALF) / (2 * HALF), (z + HALF) / (2 * HALF)) for x, _, z in pts])
    m.CreateFaceVertexCountsAttr([4] * columns)
    # point 2i is (x_i, -HALF), 2i+1 is (x_i, HALF): counter-clockwise seen from +Y
    m.CreateFaceVertexIndicesAttr([k for i in range(columns) for k in (2 * i, 2 * i + 1, 2 * i + 3, 2 * i + 2)])
    return m


def near(pixels, want):
    """The mean of `pixels` (N x 3) is `want` within 4 standard errors (hero-wavelength colour
    noise) plus 0.5 % and 1e-3 for the spectral round trip."""
    px = np.asarray(pixels, dtype=np.float64).reshape(-1, 3)
    mean, se = px.mean(axis=0), px.std(axis=0, ddof=1) / np.sqrt(len(px))
    want = np.broadcast_to(np.asarray(want, dtype=np.float64), mean.shape)
    return bool(np.all(np.abs(mean - want) < 4 * se + 0.005 * want + 1e-3)), (mean, se, want)


def shader_node(stage, path, node_id, **inputs):
    """A MaterialX node `node_id` with `inputs`: floats, 3-tuples (colours), strings (file
    paths or tokens) or the outputs of other nodes."""
    sh = UsdShade.Shader.Define(stage, path)
    sh.CreateIdAttr(node_id)
    for k, v in inputs.items():
        if isinstance(v, UsdShade.Output):
            sh.CreateInput(k, v.GetTypeName()).ConnectToSource(v)
        elif isinstance(v, tuple):
            sh.CreateInput(k, Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*v))
        elif isinstance(v, str) and k == "file":
            sh.CreateInput(k, Sdf.ValueTypeNames.Asset).Set(v)
        elif isinstance(v, str):
            sh.CreateInput(k, Sdf.ValueTypeNames.String).Set(v)
        else:
            sh.CreateInput(k, Sdf.ValueTypeNames.Float).Set(v)
    return sh


def white_dome(stage):
    """A white dome of radiance 1."""
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr(Gf.Vec3f(1, 1, 1))


def write_exr(path, rgb, **header):
    """An RGB float EXR of `rgb` (rows of (r, g, b)), with extra `header` attributes."""
    rgb = np.ascontiguousarray(rgb, dtype=np.float32)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **header},
                 {"RGB": rgb}).write(str(path))
