"""Native instances read from the first instance like them (the reader's shortcut for large,
nested instancing) against every instance walked (usd_reader.SHARE_INSTANCES = False): the
delegate must receive the same prims and values, the instances in the same order."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, floats, load, preview_material, settings
from tide import fake, usd_reader


def _class(stage, path):
    prim = stage.DefinePrim(path, "Xform")
    stage.GetRootLayer().GetPrimAtPath(path).specifier = Sdf.SpecifierClass
    return prim


def _instance(stage, path, of, translate=(0, 0, 0), rotate=0.0, scale=1.0):
    x = UsdGeom.Xform.Define(stage, path)
    x.AddTranslateOp().Set(Gf.Vec3d(*translate))
    x.AddRotateYOp().Set(rotate)
    x.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
    x.GetPrim().GetReferences().AddInternalReference(of)
    x.GetPrim().SetInstanceable(True)
    return x.GetPrim()


def _forest(stage):
    """Trees of branches of leaves, three levels of native instancing, with what makes
    instances differ: bindings on instance roots and above (one stronger than descendants), a
    binding inside a prototype, a purpose, an invisible instance, per-instance colours (on
    trees, and on branches within a bush's prototype), a light inside a prototype, a collection
    binding."""
    camera(stage, pos=(0, 2, 40))
    settings(stage)
    looks = {name: preview_material(stage, "/Looks/" + name, color=c) for name, c in
             [("Inner", (0.1, 0.2, 0.3)), ("Red", (1, 0, 0)), ("Blue", (0, 0, 1)),
              ("Green", (0, 1, 0))]}
    _class(stage, "/Leaf")
    UsdGeom.Sphere.Define(stage, "/Leaf/S").CreateRadiusAttr(0.1)
    c = UsdGeom.Cube.Define(stage, "/Leaf/C")
    c.AddTranslateOp().Set(Gf.Vec3d(0, 0.3, 0))
    bind(c.GetPrim(), looks["Inner"])
    _class(stage, "/Branch")
    for i in range(3):
        leaf = _instance(stage, "/Branch/L%d" % i, "/Leaf", (0.5 * i, 0.2 * i, 0), 30.0 * i, 1 + 0.1 * i)
        if i == 1:
            bind(leaf, looks["Red"])
    _class(stage, "/Tree")
    for i in range(4):
        _instance(stage, "/Tree/B%d" % i, "/Branch", (0, i, 0), 90.0 * i, 0.8)
    # a bush whose leaves inherit colours from outside their own instances: one branch's own
    # (within the bush's prototype), the other's from the bush
    _class(stage, "/Bush")
    for i in range(2):
        branch = _instance(stage, "/Bush/B%d" % i, "/Branch", (i, 0, 0), 10.0 * i, 0.5)
        if i == 0:
            UsdGeom.PrimvarsAPI(branch).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                      UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.2, 0.5, 0.5)])
    UsdGeom.Cylinder.Define(stage, "/Tree/Trunk")
    _class(stage, "/Lamp")
    UsdLux.SphereLight.Define(stage, "/Lamp/Bulb").CreateRadiusAttr(0.2)
    UsdGeom.Sphere.Define(stage, "/Lamp/Shade")
    UsdGeom.Xform.Define(stage, "/World")
    trees = [_instance(stage, "/World/T%d" % i, "/Tree", (3.0 * i, 0, -i), 17.0 * i) for i in range(8)]
    bind(trees[1], looks["Blue"])
    UsdShade.MaterialBindingAPI.Apply(trees[2]).Bind(looks["Green"], UsdShade.Tokens.strongerThanDescendants)
    UsdGeom.Imageable(trees[3]).MakeInvisible()
    UsdGeom.PrimvarsAPI(trees[4]).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.constant).Set([Gf.Vec3f(1, 1, 0)])
    UsdGeom.PrimvarsAPI(trees[5]).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.constant).Set([Gf.Vec3f(0, 1, 1)])
    UsdGeom.Imageable(trees[6]).CreatePurposeAttr(UsdGeom.Tokens.proxy)
    bind(trees[7], looks["Green"])  # as trees[2], but weaker than the leaves' own bindings
    group = UsdGeom.Xform.Define(stage, "/World/Group")
    group.AddTranslateOp().Set(Gf.Vec3d(0, 10, 0))
    bind(group.GetPrim(), looks["Blue"])
    for i in range(3):
        _instance(stage, "/World/Group/T%d" % i, "/Tree", (2.0 * i, 0, 0), 45.0 * i)
    for i in range(2):
        _instance(stage, "/World/Lamp%d" % i, "/Lamp", (0, 5, 3.0 * i))
        bush = _instance(stage, "/World/Bush%d" % i, "/Bush", (-3.0, 0, 2.0 * i))
        UsdGeom.PrimvarsAPI(bush).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                UsdGeom.Tokens.constant).Set([Gf.Vec3f(0.9, 0.1, 0.3 * i)])
    # a collection binding picks one leaf of one of two trees
    coll = UsdGeom.Xform.Define(stage, "/World/Picked").GetPrim()
    for i in range(2):
        _instance(stage, "/World/Picked/T%d" % i, "/Tree", (-6.0, 0, 3.0 * i))
    picked = Usd.CollectionAPI.Apply(coll, "picked")
    picked.CreateIncludesRel().AddTarget("/World/Picked/T1/B2/L0")
    UsdShade.MaterialBindingAPI.Apply(coll).Bind(picked, looks["Red"], "picked")


def _read(stage, share, monkeypatch, **opts):
    monkeypatch.setattr(usd_reader, "SHARE_INSTANCES", share)
    walked = []
    collect = usd_reader.Reader._collect_instanced
    monkeypatch.setattr(usd_reader.Reader, "_collect_instanced",
                        lambda self, prim: walked.append(prim) or collect(self, prim))
    d = fake.RenderDelegate()
    _, problems = load(stage, d, **opts)
    return d, problems, len(walked)


def _same(a, b):
    """The two delegates hold the same prims and values; instance matrices to round-off."""
    assert a.prims == b.prims
    for path in a.prims:
        va, vb = a.values[path], b.values[path]
        assert va.keys() == vb.keys(), path
        for key in va:
            if key == "instanceTransforms":
                assert va[key].keys() == vb[key].keys(), path
                for t in va[key]:
                    ma, mb = floats(va[key][t]), floats(vb[key][t])
                    assert ma.shape == mb.shape and np.allclose(ma, mb, rtol=0, atol=1e-12), path
            else:
                assert va[key] == vb[key], (path, key)
    assert a.primvars == b.primvars


def test_instances_placed_from_the_first_like_them_match_every_instance_walked(stage, monkeypatch):
    _forest(stage)
    shared, p_shared, walked_shared = _read(stage, True, monkeypatch)
    every, p_every, walked_every = _read(stage, False, monkeypatch)
    _same(shared, every)
    assert p_shared == p_every
    # what sets instances apart was seen: the leaves' materials (their own, a branch's red, a
    # tree's blue, a tree's green stronger than the leaves' own), a lamp per instance
    sphere_groups = shared.of_type("sphere")
    assert len(shared.of_type("sphereLight")) == 2
    materials = {shared.value(p, "material")[1] for p in sphere_groups}
    assert {"/Looks/Red", "/Looks/Blue", "/Looks/Green", ""} <= materials, materials
    # the instances alike were placed, not walked. Walking every one reads 11 drawn trees of
    # 25 gprims (4 branches of 3 leaves of 2, and a trunk), 2 lamp shades and 2 bushes of 12.
    # Placing reads 5 gprims of the first tree (a branch's first leaf and its red one; the other
    # leaf and branches are placed), 5 of each tree bound otherwise (blue, green stronger than
    # descendants, green weaker: the group's blue trees are alike the blue one), 5 of the
    # first coloured tree (the other takes its own colour), 4 of the first bush (its branch
    # coloured within it; its other branch is alike the coloured tree's, and the other bush
    # takes its own colour), the shades (each lamp is read on its own, for its light), and all
    # of the trees under a collection binding.
    assert (walked_every, walked_shared) == (11 * 25 + 2 + 2 * 12, 5 * 5 + 4 + 2 + 2 * 25)


def test_moving_instances_are_walked_each(stage, monkeypatch):
    """Instances whose roots move over the shutter are read one by one, as before; alike
    static ones beside them are still placed."""
    _forest(stage)
    moving = stage.GetPrimAtPath("/World/Group/T1")  # alike /World/T1 but for its motion
    op = UsdGeom.Xformable(moving).GetOrderedXformOps()[0]
    op.Set(Gf.Vec3d(0, 0, 0), 0)
    op.Set(Gf.Vec3d(1, 0, 0), 1)
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/Cam"))
    cam.CreateShutterOpenAttr(0.0)
    cam.CreateShutterCloseAttr(1.0)
    shared, p_shared, walked_shared = _read(stage, True, monkeypatch)
    every, p_every, walked_every = _read(stage, False, monkeypatch)
    _same(shared, every)
    assert p_shared == p_every and walked_shared < walked_every
    moved = [p for p in shared.of_type("sphere") if len(shared.samples(p, "instanceTransforms")) > 1]
    assert moved, "a moving tree gives its leaves motion samples"
