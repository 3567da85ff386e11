"""Writes a stage of 20000 instances for the top-level BVH: a PointInstancer of a 96-quad
sphere scattered over 80 x 8 x 60 units above a ground plane, under a dome and a sun, seen by
a 160x90 camera with the path integrator.

    .venv/bin/python bench/instances_stage.py OUT.usda
    ./tide render OUT.usda --spp 16 --threads 1     # samples/s in the summary line
"""
import sys

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, Vt


def main(path, n=20000):
    s = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
    cam = UsdGeom.Camera.Define(s, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 6, 30))
    cam.AddRotateXOp().Set(-12)
    UsdLux.DomeLight.Define(s, "/Dome").CreateIntensityAttr(1.0)
    sun = UsdLux.DistantLight.Define(s, "/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.AddRotateXOp().Set(-50)
    g = UsdGeom.Mesh.Define(s, "/Ground")
    g.CreatePointsAttr([(-50, 0, -50), (50, 0, -50), (50, 0, 50), (-50, 0, 50)])
    g.CreateFaceVertexCountsAttr([4])
    g.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    pi = UsdGeom.PointInstancer.Define(s, "/PI")
    proto = UsdGeom.Mesh.Define(s, "/PI/Protos/Rock")
    nu, nv = 12, 8
    pts = [(np.sin(np.pi * j / nv) * np.cos(2 * np.pi * i / nu), np.cos(np.pi * j / nv),
            np.sin(np.pi * j / nv) * np.sin(2 * np.pi * i / nu)) for j in range(nv + 1) for i in range(nu)]
    idx = []
    for j in range(nv):
        for i in range(nu):
            a, b = j * nu + i, j * nu + (i + 1) % nu
            idx += [a, b, b + nu, a + nu]
    proto.CreatePointsAttr(pts)
    proto.CreateFaceVertexIndicesAttr(idx)
    proto.CreateFaceVertexCountsAttr([4] * (nu * nv))
    proto.CreateSubdivisionSchemeAttr("none")
    pi.CreatePrototypesRel().SetTargets(["/PI/Protos/Rock"])
    rng = np.random.default_rng(1)
    p = np.stack([rng.uniform(-40, 40, n), rng.uniform(0, 8, n), rng.uniform(-40, 20, n)], 1)
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(p.astype(np.float32)))
    pi.CreateProtoIndicesAttr([0] * n)
    scales = np.repeat(rng.uniform(0.1, 0.6, (n, 1)), 3, 1).astype(np.float32)
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(scales))
    st = UsdRender.Settings.Define(s, "/Render/Settings")
    st.CreateResolutionAttr(Gf.Vec2i(160, 90))
    st.CreateCameraRel().SetTargets(["/Cam"])
    st.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    s.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    s.Save()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    main(sys.argv[1])
