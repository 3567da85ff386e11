"""Load time of nested native instancing: LEVELS levels of FAN instanceable references each
(FAN**LEVELS spheres, e.g. a forest of trees of branches of leaves), read through the usd-core
reader and committed to the delegate. Prints the reader's and the commit's times and the
process's peak RSS.

    .venv/bin/python bench/front_door_native_instances.py [--fan 10] [--levels 5] [--colours] [REPO_ROOT]

--colours gives each instance (of every level) its own displayColor, which its leaves inherit.

REPO_ROOT (default: this checkout) picks the `tide` package whose reader and module are
measured, so an earlier build can be measured by the same script.
"""
import argparse
import os
import sys

from measure import THIS_CHECKOUT, load_timed, peak_mib, tide_from

ap = argparse.ArgumentParser()
ap.add_argument("--fan", type=int, default=10)
ap.add_argument("--levels", type=int, default=5)
ap.add_argument("--colours", action="store_true", help="each instance its own displayColor")
ap.add_argument("root", nargs="?", default=THIS_CHECKOUT)
args = ap.parse_args()
usd_reader, module = tide_from(args.root)
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender

s = Usd.Stage.CreateInMemory()
UsdGeom.SetStageUpAxis(s, "Y")
UsdGeom.Camera.Define(s, "/Cam").AddTranslateOp().Set(Gf.Vec3d(0, 0, 50))
UsdLux.DomeLight.Define(s, "/Dome")
st = UsdRender.Settings.Define(s, "/Render/S")
st.CreateResolutionAttr(Gf.Vec2i(32, 32))
st.CreateCameraRel().SetTargets(["/Cam"])
s.CreateClassPrim("/L0")
UsdGeom.Sphere.Define(s, "/L0/S").CreateRadiusAttr(0.01)
for k in range(1, args.levels + 1):
    s.CreateClassPrim("/L%d" % k)
    UsdGeom.Xform.Define(s, "/L%d" % k)
    for i in range(args.fan):
        x = UsdGeom.Xform.Define(s, "/L%d/I%d" % (k, i))
        x.AddTranslateOp().Set(Gf.Vec3d(i * 0.05, 0, 0))
        x.AddRotateYOp().Set(10.0 * k)
        x.GetPrim().GetReferences().AddInternalReference("/L%d" % (k - 1))
        x.GetPrim().SetInstanceable(True)
        if args.colours:
            UsdGeom.PrimvarsAPI(x).CreatePrimvar("displayColor", Sdf.ValueTypeNames.Color3fArray,
                                                 UsdGeom.Tokens.constant).Set([Gf.Vec3f(i / args.fan, k / args.levels, 0.5)])
top = UsdGeom.Xform.Define(s, "/World")
top.GetPrim().GetReferences().AddInternalReference("/L%d" % args.levels)
top.GetPrim().SetInstanceable(True)

_, read_s, commit_s, problems = load_timed(usd_reader, module, s)


print("%d^%d = %d nested native instances%s: reader %.2f s, commit %.2f s, peak %.0f MiB%s"
      % (args.fan, args.levels, args.fan ** args.levels, " with colours" if args.colours else "", read_s, commit_s, peak_mib(),
         "; problems: %s" % problems if problems else ""))
