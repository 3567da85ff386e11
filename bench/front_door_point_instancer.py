"""Load time of a large PointInstancer: COUNT instances of two prototypes scattered in a box
(a tenth hidden by invisibleIds), read through the usd-core reader and committed to the
delegate; with --moving, velocities and accelerations too (the instances then move over the
half-frame shutter), with --spinning angular velocities as well. Prints the reader's and the
commit's times and the process's peak RSS.

    .venv/bin/python bench/front_door_point_instancer.py [--count 1000000] [--moving [--spinning]] [--save STAGE] [REPO_ROOT]

REPO_ROOT (default: this checkout) picks the `tide` package whose reader and module are
measured, so an earlier build can be measured by the same script.
"""
import argparse

import numpy as np

from measure import THIS_CHECKOUT, load_timed, peak_mib, tide_from

ap = argparse.ArgumentParser()
ap.add_argument("--count", type=int, default=1000000)
ap.add_argument("--moving", action="store_true", help="velocities and accelerations")
ap.add_argument("--spinning", action="store_true", help="with --moving: angular velocities too")
ap.add_argument("--save", metavar="STAGE", help="also write the authored stage there (to time `tide render` on it)")
ap.add_argument("root", nargs="?", default=THIS_CHECKOUT)
args = ap.parse_args()
usd_reader, module = tide_from(args.root)
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, Vt

n = args.count
s = Usd.Stage.CreateInMemory()
cam = UsdGeom.Camera.Define(s, "/Cam")
cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 50))
if args.moving:
    cam.CreateShutterOpenAttr(-0.25)
    cam.CreateShutterCloseAttr(0.25)
UsdLux.DomeLight.Define(s, "/Dome")
st = UsdRender.Settings.Define(s, "/Render/S")
st.CreateResolutionAttr(Gf.Vec2i(32, 32))
st.CreateCameraRel().SetTargets(["/Cam"])
pi = UsdGeom.PointInstancer.Define(s, "/World/Scatter")
ball = UsdGeom.Sphere.Define(s, "/World/Scatter/Protos/Ball")
ball.CreateRadiusAttr(0.05)
box = UsdGeom.Cube.Define(s, "/World/Scatter/Protos/Box")
box.CreateSizeAttr(0.08)
pi.CreatePrototypesRel().SetTargets([ball.GetPath(), box.GetPath()])
rng = np.random.default_rng(1)
pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(-20, 20, (n, 3)).astype(np.float32)))
pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy((np.arange(n) % 2).astype(np.int32)))
pi.CreateInvisibleIdsAttr(Vt.Int64Array.FromNumpy(np.arange(0, n, 10, dtype=np.int64)))
if args.moving:
    pi.CreateVelocitiesAttr(Vt.Vec3fArray.FromNumpy(rng.normal(0, 1, (n, 3)).astype(np.float32)))
    pi.CreateAccelerationsAttr(Vt.Vec3fArray.FromNumpy(np.tile(np.float32([0, -9.8, 0]), (n, 1))))
    if args.spinning:
        pi.CreateAngularVelocitiesAttr(Vt.Vec3fArray.FromNumpy(rng.normal(0, 360, (n, 3)).astype(np.float32)))

if args.save:
    s.GetRootLayer().Export(args.save)
_, read_s, commit_s, problems = load_timed(usd_reader, module, s)
print("%d PointInstancer instances%s: reader %.2f s, commit %.2f s, peak %.0f MiB%s"
      % (n, (" spinning" if args.spinning else "") + (" moving" if args.moving else ""), read_s, commit_s, peak_mib(),
         "; problems: %s" % problems if problems else ""))
