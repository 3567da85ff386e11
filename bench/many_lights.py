"""Many lights: 20000 small sphere lights (radius 0.1, intensity 50) scattered over
120 x 20 x 80 units above a ground plane, path integrator, 160x90.

    .venv/bin/python bench/many_lights.py stage OUT.usda [--down] [--spots]
        writes the stage; the camera looks along the ground from (0, 5, 40), or with --down
        straight down at it from 0.4 units (no light in view: the image is all next-event
        estimation); with --spots every light is a spot pointing down (a 20° cone)
    .venv/bin/python bench/many_lights.py error REF.exr IMAGE.exr [IMAGE.exr ...]
        each image's RMSE against the reference, over the reference's mean, and its mean

Samples/s are in `./tide render OUT.usda --spp 16` summary line; the equal-sample error is
`error` on a 1024-spp reference and 16-spp images of other seeds (`--seed`).
"""
import math
import random
import sys


def stage(path, down=False, n=20000, spots=False):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender

    s = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    cam = UsdGeom.Camera.Define(s, "/Cam")
    if down:
        cam.CreateFocalLengthAttr(10.0)
        cam.CreateClippingRangeAttr(Gf.Vec2f(0.01, 1000.0))
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 0.4, 0))
        cam.AddRotateXOp().Set(-90)
    else:
        cam.AddTranslateOp().Set(Gf.Vec3d(0, 5, 40))
    g = UsdGeom.Mesh.Define(s, "/Ground")
    g.CreatePointsAttr([(-100, 0, -100), (-100, 0, 100), (100, 0, 100), (100, 0, -100)])
    g.CreateFaceVertexCountsAttr([4])
    g.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    rng = random.Random(3)
    UsdGeom.Scope.Define(s, "/Lights")
    for i in range(n):
        light = UsdLux.SphereLight.Define(s, "/Lights/l%d" % i)
        light.CreateRadiusAttr(0.1)
        light.CreateIntensityAttr(50.0)
        light.AddTranslateOp().Set(Gf.Vec3d(rng.uniform(-60, 60), rng.uniform(0.5, 20), rng.uniform(-60, 20)))
        if spots:
            # the light's −Z turned to point down
            light.AddRotateXOp().Set(-90.0)
            UsdLux.ShapingAPI.Apply(light.GetPrim()).CreateShapingConeAngleAttr(20.0)
    settings = UsdRender.Settings.Define(s, "/Render/Settings")
    settings.CreateCameraRel().SetTargets(["/Cam"])
    settings.CreateResolutionAttr(Gf.Vec2i(160, 90))
    settings.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    product = UsdRender.Product.Define(s, "/Render/Product")
    settings.CreateProductsRel().SetTargets([product.GetPath()])
    var = UsdRender.Var.Define(s, "/Render/Vars/color")
    var.CreateSourceNameAttr("color")
    product.CreateOrderedVarsRel().SetTargets([var.GetPath()])
    s.GetRootLayer().Save()


def error(ref_path, paths):
    import OpenEXR
    import array

    def load(p):
        f = OpenEXR.InputFile(p)
        return [array.array("f", f.channel(c)) for c in "RGB"]

    ref = load(ref_path)
    n = len(ref[0])
    mean = sum(sum(c) for c in ref) / (3 * n)
    for p in paths:
        a = load(p)
        rmse = math.sqrt(sum((a[c][i] - ref[c][i]) ** 2 for c in range(3) for i in range(n)) / (3 * n))
        print("%s: relative RMSE %.4f, mean %.5f (reference %.5f)"
              % (p, rmse / mean, sum(sum(c) for c in a) / (3 * n), mean))


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "stage":
        stage(sys.argv[2], down="--down" in sys.argv[3:], spots="--spots" in sys.argv[3:])
    elif len(sys.argv) >= 4 and sys.argv[1] == "error":
        error(sys.argv[2], sys.argv[3:])
    else:
        sys.exit(__doc__)
