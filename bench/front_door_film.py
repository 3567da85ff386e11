"""Peak memory of a large frame: `./tide render` of a near-empty stage (a camera, a tiny
sphere, a sun; the path integrator at 1 spp) at SIZE × SIZE, with the colour AOV only and with
every AOV of the contract, in one fresh process each:

    .venv/bin/python bench/front_door_film.py [--size 4096] [CHECKOUT]

The peak is the process's maximum resident set (the film's accumulators, the tiles in flight, the
bound buffers, the EXR and the PNG preview being written); CHECKOUT measures another build.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
ALL = ["color", "depth", "normal", "albedo", "primId", "tide:diffuse", "tide:specular",
       "tide:transmission", "tide:volume", "tide:emission", "tide:caustics"]


def stage(path, size, aovs):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender
    st = Usd.Stage.CreateNew(path)
    UsdGeom.Camera.Define(st, "/cam").AddTranslateOp().Set(Gf.Vec3d(0, 0, 5))
    UsdGeom.Sphere.Define(st, "/ball").GetRadiusAttr().Set(0.01)
    UsdLux.DistantLight.Define(st, "/sun")
    rs = UsdRender.Settings.Define(st, "/Render/settings")
    rs.GetResolutionAttr().Set(Gf.Vec2i(size, size))
    rs.GetCameraRel().SetTargets(["/cam"])
    rs.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    rs.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(1)
    prod = UsdRender.Product.Define(st, "/Render/product")
    prod.GetProductNameAttr().Set("out.exr")
    targets = []
    for a in aovs:
        v = UsdRender.Var.Define(st, "/Render/vars/" + a.replace(":", "_"))
        v.GetSourceNameAttr().Set(a)
        targets.append(v.GetPath())
    prod.GetOrderedVarsRel().SetTargets(targets)
    rs.GetProductsRel().SetTargets([prod.GetPath()])
    st.SetMetadata("renderSettingsPrimPath", "/Render/settings")
    st.GetRootLayer().Save()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("checkout", nargs="?", default=ROOT)
    args = ap.parse_args()
    tide = os.path.join(os.path.abspath(args.checkout), "tide")
    with tempfile.TemporaryDirectory() as d:
        for name, aovs in (("colour", ["color"]), ("every AOV", ALL)):
            path = os.path.join(d, "film.usda")
            stage(path, args.size, aovs)
            # each render in its own child of a fresh measuring process, so its peak is its own
            code = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
                    "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.stderr.write(r.stderr[-300:])")
            out = subprocess.run([sys.executable, "-c", code, tide, "render", path, "-o", os.path.join(d, "out.exr")],
                                 capture_output=True, text=True, cwd=d)
            rc, kb = out.stdout.split()
            if rc != "0":
                sys.exit("render failed: " + out.stderr)
            print("%d² %-9s peak %7.0f MiB" % (args.size, name, int(kb) / 1024.0))


if __name__ == "__main__":
    main()
