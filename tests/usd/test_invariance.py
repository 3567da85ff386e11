"""What must not change an image. Rewritings of a stage that compose to the same stage (a
sublayer over it, binary crate instead of text, flattened, default values as one time sample,
prims' contents moved into a selected variant, properties moved into an inherited class,
opinions split over two layers, an identity transform op) render bit for bit the image the
stage renders. And a stage whose every root prim is scaled by s with its `metersPerUnit`
divided by s is the same physical scene (its ocean's own lengths are of its space, so the
scale is undone there; a normalized light keeps its power while its size changes, so it is
left out): it renders the same image, to within the noise of another seed; so does a stage
mirrored with its camera. Stage: every kind of prim of the contract (data/every_prim.usda),
rendered small through `tide render`, and the fog bank example."""
import os
import subprocess

import numpy as np
import OpenEXR
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom

from conftest import ROOT, linked_assets

TIDE = os.path.join(ROOT, "tide")
DATA = os.path.join(os.path.dirname(__file__), "data")
EVERY = os.path.join(DATA, "every_prim.usda")


def _render(path, out, *extra):
    r = subprocess.run([TIDE, "render", path, "-o", out, "--width", "48", "--threads", "2"] + list(extra),
                       cwd=os.path.dirname(out), capture_output=True, text=True,
                       stdin=subprocess.DEVNULL, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    with OpenEXR.File(out, separate_channels=True) as f:
        px = {k: np.array(v.pixels) for k, v in f.channels().items()}
    return px, sorted(line for line in r.stderr.splitlines() if line.startswith("tide: problem:"))


def _base(tmp_path):
    """every_prim.usda and the files it reads (its VDB is the example stages'), in
    `tmp_path`."""
    linked_assets(str(tmp_path))
    src = str(tmp_path / "base.usda")
    Sdf.Layer.FindOrOpen(EVERY).Export(src)
    return src


def _sublayer(src, dst):
    layer, new = Sdf.Layer.FindOrOpen(src), Sdf.Layer.CreateNew(dst)
    for key in layer.pseudoRoot.ListInfoKeys():
        if key not in ("subLayers", "subLayerOffsets", "primChildren"):
            new.pseudoRoot.SetInfo(key, layer.pseudoRoot.GetInfo(key))
    new.subLayerPaths.append(os.path.basename(src))
    new.Save()
    return dst


def _crate(src, dst):
    dst = dst.replace(".usda", ".usdc")
    Sdf.Layer.FindOrOpen(src).Export(dst)
    return dst


def _flattened(src, dst):
    Usd.Stage.Open(src).Flatten().Export(dst)
    return dst


def _copy(src):
    new = Sdf.Layer.CreateAnonymous(".usda")
    new.TransferContent(Sdf.Layer.FindOrOpen(src))
    return new


def _time_samples(src, dst):
    """Every varying default value as one time sample at the frame rendered (a single sample
    holds at every time); schema-uniform attributes (read at the default time) are left."""
    new, stage = _copy(src), Usd.Stage.Open(src)
    frame = float(stage.GetStartTimeCode()) if stage.HasAuthoredTimeCodeRange() else 0.0
    paths = []
    new.Traverse(Sdf.Path.absoluteRootPath, lambda p: paths.append(p) if p.IsPropertyPath() else None)
    for path in paths:
        spec = new.GetAttributeAtPath(path)
        if spec is None or not spec.HasDefaultValue() or spec.default is None:
            continue
        attr = stage.GetAttributeAtPath(path)
        if spec.variability == Sdf.VariabilityUniform or new.GetNumTimeSamplesForPath(path) or \
                (attr and attr.GetVariability() == Sdf.VariabilityUniform):
            continue
        new.SetTimeSample(path, frame, spec.default)
        spec.ClearDefaultValue()
    new.Export(dst)
    return dst


def _in_a_variant(src, dst):
    new = _copy(src)
    for root in list(new.rootPrims):
        if root.specifier != Sdf.SpecifierDef:
            continue
        Sdf.VariantSpec(Sdf.VariantSetSpec(root, "look"), "chosen")
        root.variantSelections["look"] = "chosen"
        root.variantSetNameList.Prepend("look")
        inside = root.path.AppendVariantSelection("look", "chosen")
        for child in list(root.nameChildren):
            assert Sdf.CopySpec(new, child.path, new, inside.AppendChild(child.name))
            del root.nameChildren[child.name]
        for prop in list(root.properties):
            assert Sdf.CopySpec(new, prop.path, new, inside.AppendProperty(prop.name))
            root.RemoveProperty(prop)
    new.Export(dst)
    return dst


def _inherited(src, dst):
    new, stage = _copy(src), Usd.Stage.Open(src)
    for n, prim in enumerate(p for p in stage.Traverse() if not p.IsInstanceProxy()):
        spec = new.GetPrimAtPath(prim.GetPath())
        if spec is None or not spec.properties or not (prim.IsA(UsdGeom.Gprim) or "Light" in prim.GetTypeName()):
            continue
        cls = Sdf.CreatePrimInLayer(new, "/_class%d" % n)
        cls.specifier = Sdf.SpecifierClass
        for prop in list(spec.properties):
            assert Sdf.CopySpec(new, prop.path, new, cls.path.AppendProperty(prop.name))
            spec.RemoveProperty(prop)
        spec.inheritPathList.Prepend(cls.path)
    new.Export(dst)
    return dst


def _split(src, dst):
    strong = _copy(src)
    weak = Sdf.Layer.CreateNew(dst.replace(".usda", "_weak.usda"))
    paths = []
    strong.Traverse(Sdf.Path.absoluteRootPath, lambda p: paths.append(p) if p.IsPropertyPath() else None)
    for path in sorted(paths)[::2]:
        spec = strong.GetPropertyAtPath(path)
        if isinstance(spec, Sdf.AttributeSpec):
            Sdf.CreatePrimInLayer(weak, path.GetPrimPath())
            assert Sdf.CopySpec(strong, path, weak, path)
            strong.GetPrimAtPath(path.GetPrimPath()).RemoveProperty(spec)
    weak.Save()
    strong.subLayerPaths.append(os.path.basename(weak.identifier))
    strong.Export(dst)
    return dst


def _identity_op(src, dst):
    stage = Usd.Stage.Open(src)
    for prim in stage.Traverse():
        x = UsdGeom.Xformable(prim)
        if x and not prim.IsInstanceProxy():
            ops = x.GetOrderedXformOps()
            op = x.AddTranslateOp(opSuffix="identity")
            op.Set(Gf.Vec3d(0, 0, 0))
            x.SetXformOpOrder([op] + list(ops), x.GetResetXformStack())
    stage.GetRootLayer().Export(dst)
    return dst


REWRITES = {"sublayer": _sublayer, "crate": _crate, "flattened": _flattened,
            "time_samples": _time_samples, "variant": _in_a_variant, "inherited": _inherited,
            "split": _split, "identity_op": _identity_op}


def test_rewritings_that_compose_alike_render_alike(renderer, tmp_path):
    src = _base(tmp_path)
    want, want_problems = _render(src, str(tmp_path / "base.exr"), "--spp", "2")
    for name, rewrite in REWRITES.items():
        path = rewrite(src, str(tmp_path / ("%s.usda" % name)))
        got, problems = _render(path, str(tmp_path / ("%s.exr" % name)), "--spp", "2")
        assert sorted(got) == sorted(want), name
        differ = [k for k in want if not np.array_equal(got[k], want[k], equal_nan=True)]
        assert not differ, "%s: channels %s differ" % (name, differ)
        assert problems == want_problems, (name, set(problems) ^ set(want_problems))


def _prepend_scale(stage, scale, suffix):
    """Puts every top transformable prim (a root prim, or the first below a root that is not)
    under `scale`, its outermost op."""
    tops, todo = [], list(stage.GetPseudoRoot().GetChildren())
    while todo:
        p = todo.pop()
        if UsdGeom.Xformable(p):
            tops.append(p)
        else:
            todo.extend(p.GetChildren())
    for p in tops:
        x = UsdGeom.Xformable(p)
        ops = x.GetOrderedXformOps()
        op = x.AddScaleOp(UsdGeom.XformOp.PrecisionDouble, opSuffix=suffix)
        op.Set(Gf.Vec3d(*scale))
        x.SetXformOpOrder([op] + list(ops), x.GetResetXformStack())


def _scaled(src, dst, s):
    stage = Usd.Stage.Open(src)
    stage.GetPrimAtPath("/Lights/Disk").SetActive(False)
    if s != 1.0:
        _prepend_scale(stage, (s, s, s), "units")
        for p in stage.Traverse():
            if p.GetTypeName() == "TideOcean":
                x = UsdGeom.Xformable(p)
                ops = x.GetOrderedXformOps()
                op = x.AddScaleOp(UsdGeom.XformOp.PrecisionDouble, opSuffix="undone")
                op.Set(Gf.Vec3d(1 / s, 1 / s, 1 / s))
                x.SetXformOpOrder(list(ops) + [op], x.GetResetXformStack())
        UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.GetStageMetersPerUnit(stage) / s)
    stage.GetRootLayer().Export(dst)
    return dst


def _blocks(px, size=8):
    img = np.stack([px[c] for c in "RGB"], -1).astype(np.float64)
    h, w = img.shape[0] // size * size, img.shape[1] // size * size
    return img[:h, :w].reshape(h // size, size, w // size, size, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("s", [100.0, 0.001])
def test_a_stage_in_other_units_renders_the_same_scene(renderer, tmp_path, s):
    src = _base(tmp_path)
    plain = _scaled(src, str(tmp_path / "plain.usda"), 1.0)
    # nothing is refused at one size and not the other (the droplets' grid, say)
    _same_scene(plain, _scaled(src, str(tmp_path / "scaled.usda"), s), tmp_path)


def _same_scene(src, other, tmp_path):
    """Renders `src` at two seeds and `other` at the first: the same problems, and the same
    image to within the noise between the seeds."""
    a, problems = _render(src, str(tmp_path / "a.exr"), "--spp", "64")
    b, _ = _render(src, str(tmp_path / "b.exr"), "--spp", "64", "--seed", "1")
    c, other_problems = _render(other, str(tmp_path / "c.exr"), "--spp", "64")
    assert other_problems == problems
    ba, bb, bc = _blocks(a), _blocks(b), _blocks(c)
    rel = lambda x, y: np.abs(x - y) / (np.abs(x) + np.abs(y) + 1e-3)  # noqa: E731
    noise, off = rel(ba, bb).max(), rel(ba, bc).max()
    # the same seed follows the same paths where rounding allows: most blocks agree closely,
    # and none differs by more than two seeds' blocks do
    assert np.median(rel(ba, bc)) < 0.01, np.median(rel(ba, bc))
    assert off <= 1.5 * noise, (off, noise, np.unravel_index(np.argmax(rel(ba, bc)), ba.shape))


@pytest.mark.parametrize("name", ["every_prim.usda", "fog_bank.usda"])
def test_a_stage_mirrored_camera_and_all_renders_the_same_image(renderer, tmp_path, name):
    """Every root prim, the camera with them, mirrored through x = 0: each point is seen from
    the mirrored camera where it was seen before, so the image is the same (a volume's box
    turned inside out let the fog bank's light through unattenuated)."""
    linked_assets(str(tmp_path))
    src = str(tmp_path / "base.usda")
    Sdf.Layer.FindOrOpen(EVERY if name == "every_prim.usda" else os.path.join(ROOT, "docs", "stages", name)).Export(src)
    stage = Usd.Stage.Open(src)
    _prepend_scale(stage, (-1.0, 1.0, 1.0), "mirror")
    mirrored = str(tmp_path / "mirrored.usda")
    stage.GetRootLayer().Export(mirrored)
    _same_scene(src, mirrored, tmp_path)
