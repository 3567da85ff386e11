"""Memory and speed of volumes read from OpenVDB files: a dense cloud (a ball of fog SIZE³
voxels, every one of them non-zero) rendered 160x90 with scattering, and a sparse grid (BLOBS
blocks of 6³ voxels scattered through a box EXTENT voxels wide, as spray or foam is). Prints,
for each, the load time (the VDB read, the reader and the commit), the render's samples per
second (the dense cloud) and the process's peak RSS, each in a fresh process.

    .venv/bin/python bench/front_door_vdb.py [--size 192] [--blobs 400] [--extent 2048] [REPO_ROOT]

REPO_ROOT (default: this checkout) picks the `tide` package whose reader and module are
measured, so an earlier build can be measured by the same script.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

from measure import THIS_CHECKOUT, peak_mib, tide_from


def stage_for(vdb, res, spp):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdVol
    s = Usd.Stage.CreateInMemory()
    cam = UsdGeom.Camera.Define(s, "/Cam")
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 6))
    UsdLux.DomeLight.Define(s, "/Dome")
    sun = UsdLux.DistantLight.Define(s, "/Sun")
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-40, 30, 0))
    sun.CreateIntensityAttr(3.0)
    st = UsdRender.Settings.Define(s, "/Render/S")
    st.CreateResolutionAttr(Gf.Vec2i(*res))
    st.CreateCameraRel().SetTargets(["/Cam"])
    st.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(spp)
    st.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    mat = UsdShade.Material.Define(s, "/Looks/Fog")
    med = UsdShade.Shader.Define(s, "/Looks/Fog/Medium")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.2, 0.2))
    med.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(2.0, 2.0, 2.0))
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    vol = UsdVol.Volume.Define(s, "/Cloud")
    field = UsdVol.OpenVDBAsset.Define(s, "/Cloud/density")
    field.CreateFilePathAttr(vdb)
    field.CreateFieldNameAttr("density")
    vol.CreateFieldRelationship("density", field.GetPath())
    UsdShade.MaterialBindingAPI.Apply(vol.GetPrim()).Bind(mat)
    return s


def child(args, case, vdb):
    usd_reader, module = tide_from(args.root)
    t0 = time.monotonic()
    stage = stage_for(vdb, (160, 90), 4 if case == "dense" else 1)
    reader = usd_reader.Reader(stage, module.RenderDelegate(), usd_reader.Options())
    reader.load()
    t_load = time.monotonic() - t0
    out = {"case": case, "load_s": round(t_load, 2)}
    rp = reader.render_pass()
    ok = rp.wait(600.0)
    summary = rp.summary()
    w, h = reader.resolution
    secs = float(summary.get("renderSeconds", "nan"))
    out["samples_per_s"] = round(w * h * float(summary.get("spp", "nan")) / secs) if secs > 0 else None
    out["problems"] = [str(p.message) for p in reader.problems][:2]
    out["rendered"] = bool(ok) and rp.error() is None
    out["peak_mib"] = round(peak_mib())
    print(json.dumps(out))


def write(args, case, path):
    import numpy as np
    _, module = tide_from(args.root)
    if case == "dense":
        n = args.size
        k, j, i = np.meshgrid(*(np.arange(n, dtype=np.float32),) * 3, indexing="ij")
        r = np.sqrt((i - n / 2) ** 2 + (j - n / 2) ** 2 + (k - n / 2) ** 2) / (n / 2)
        values = np.clip(1.2 - r, 0.05, None).astype(np.float32)
        module.write_vdb(path, [("density", "float", (n, n, n), values.tobytes(), 4.0 / n, (-2, -2, -2), (0, 0, 0))])
    else:
        rng = np.random.default_rng(1)
        blob = np.full(6 * 6 * 6, 1.0, dtype=np.float32).tobytes()
        grids = [("density", "float", (6, 6, 6), blob, 4.0 / args.extent, (-2, -2, -2), tuple(int(v) for v in rng.integers(0, args.extent - 6, 3)))
                 for _ in range(args.blobs)]
        module.write_vdb(path, grids)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--blobs", type=int, default=400)
    ap.add_argument("--extent", type=int, default=2048)
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    ap.add_argument("root", nargs="?", default=THIS_CHECKOUT)
    args = ap.parse_args()
    args.root = os.path.abspath(args.root)
    if args.child:
        child(args, *args.child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        for case in ("dense", "sparse"):
            path = os.path.join(tmp, case + ".vdb")
            # written by this checkout's module, read by the measured one
            write(argparse.Namespace(**{**vars(args), "root": THIS_CHECKOUT}), case, path)
            cmd = [sys.executable, os.path.abspath(__file__), "--size", str(args.size), "--blobs", str(args.blobs),
                   "--extent", str(args.extent), "--child", case, path, args.root]
            r = subprocess.run(cmd, capture_output=True, text=True, check=False)
            print(r.stdout.strip() or "(no output) " + r.stderr.strip()[-1500:])


if __name__ == "__main__":
    main()
