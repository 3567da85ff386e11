"""Sync through the front door: a stage authored with usd-core, read by Tide's usd-core reader
into the `tide._tide` module, committed to the delegate, then the core build.

    .venv/bin/python bench/front_door_sync.py CASE [--repeats N] [--json]

CASE:
  mesh2m      one UsdGeomMesh, a 1000x1000-quad grid (2M triangles)
  points1m    one UsdGeomPoints, 1M points with per-point widths
  resync1000  1000 meshes of 200 triangles (+ camera); one prim's transform is edited and the
              reader's update() re-syncs it
  camera2m    mesh2m's grid; the camera is moved five times, each move followed by the
              restarted pass (the renderer keeps its BVH and takes the new camera)
  edit2m      mesh2m's grid and a small 200-triangle mesh; the small mesh is moved five times,
              each move followed by the restarted pass (a new world around the grid's BVH)
  edit1mpts   the same beside points1m's points

Each repeat runs in a fresh child process, so the peak RSS (VmHWM, which only grows) belongs
to that case alone. Phases, per process:
  author   building the stage with usd-core (not Tide's cost; its peak is the baseline)
  reader   Reader.populate(): USD -> protocol values -> the module's set/set_array calls
  commit   Reader.commit(): the bridge syncs dirty prims into the Rust delegate, which converts
           them and assembles the core scene
  build    execute() of a 64x36, 1-spp render pass until it finishes: the core build
           (validation, BVH, world) plus one tiny pass
  resync1000 only: edit one prim's translate op, reader.update() (notice -> re-read of that
           prim -> commit; `resync_synced` is the delegate's last_synced()), then the
           restarted pass until it finishes (`rebuild_s`)
  camera2m only: the median over five camera moves of reader.update() (`camera_update_s`)
           and of the restarted pass until it finishes (`camera_pass_s`)
  edit2m, edit1mpts only: the same medians over five moves of the small mesh
           (`edit_update_s`, `edit_pass_s`)
The medians over the repeats are printed last.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from measure import peak_mib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))


def author(case):
    import numpy as np
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdRender, Vt

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    cam = UsdGeom.Camera.Define(stage, "/Camera")
    cam.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 3.0))
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(64, 36))
    settings.GetPrim().CreateAttribute("tide:samples", Sdf.ValueTypeNames.Int).Set(1)
    settings.GetPrim().CreateAttribute("tide:integrator", Sdf.ValueTypeNames.Token).Set("path")
    settings.CreateCameraRel().SetTargets(["/Camera"])

    def grid(n):
        xs = np.linspace(0.0, 1.0, n + 1, dtype=np.float32)
        gx, gz = np.meshgrid(xs, xs)
        pts = np.stack([gx.ravel(), np.zeros(gx.size, np.float32), gz.ravel()], axis=1)
        j, i = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        a = (j * (n + 1) + i).ravel().astype(np.int32)
        idx = np.stack([a, a + n + 1, a + n + 2, a + 1], axis=1).ravel()
        return pts, np.full(n * n, 4, np.int32), idx

    def mesh(path, n, offset=(0.0, 0.0, 0.0)):
        pts, counts, idx = grid(n)
        m = UsdGeom.Mesh.Define(stage, path)
        m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
        m.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
        m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(idx))
        m.CreateSubdivisionSchemeAttr("none")
        if offset != (0.0, 0.0, 0.0):
            m.AddTranslateOp().Set(Gf.Vec3d(*offset))
        return m

    if case in ("mesh2m", "camera2m", "edit2m"):
        mesh("/World/Grid", 1000)
        if case == "edit2m":
            mesh("/World/Small", 10, (0.2, 0.1, 0.2))
    elif case in ("points1m", "edit1mpts"):
        if case == "edit1mpts":
            mesh("/World/Small", 10, (0.2, 0.1, 0.2))
        n = 1_000_000
        i = np.arange(n)
        pts = np.stack([(i % 1000) * 1e-3, ((i // 1000) % 1000) * 1e-3, np.zeros(n)],
                       axis=1).astype(np.float32)
        p = UsdGeom.Points.Define(stage, "/World/Points")
        p.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts))
        p.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.full(n, 1e-3, np.float32)))
        p.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    elif case == "resync1000":
        for k in range(1000):
            mesh("/World/M%04d" % k, 10, ((k % 40) * 1.1, 0.0, (k // 40) * 1.1))
    else:
        raise SystemExit("unknown case %r (mesh2m, points1m, resync1000, camera2m, edit2m, edit1mpts)" % case)
    return stage


def wait_pass(rp):
    while not rp.is_converged():
        if rp.wait(5.0) and not rp.is_converged():
            raise RuntimeError("render stopped: %s" % rp.error())


def child(case):
    from tide import env
    env.prepare()
    from tide import usd_reader
    module = env.load_module()
    from pxr import Gf, UsdGeom

    out = {"case": case}
    t = time.perf_counter()
    stage = author(case)
    out["author_s"] = time.perf_counter() - t
    out["hwm_author_mib"] = peak_mib()

    delegate = module.RenderDelegate()
    reader = usd_reader.Reader(stage, delegate, usd_reader.Options())
    t = time.perf_counter()
    reader.populate()
    out["reader_s"] = time.perf_counter() - t
    out["hwm_reader_mib"] = peak_mib()
    t = time.perf_counter()
    problems = reader.commit()
    out["commit_s"] = time.perf_counter() - t
    out["hwm_commit_mib"] = peak_mib()
    out["problems"] = [str(p) for p in problems]
    out["synced_initial"] = len(delegate.last_synced())
    t = time.perf_counter()
    rp = reader.render_pass()
    wait_pass(rp)
    out["build_s"] = time.perf_counter() - t
    out["hwm_build_mib"] = peak_mib()

    if case == "resync1000":
        prim = stage.GetPrimAtPath("/World/M0500")
        op = UsdGeom.Xformable(prim).GetOrderedXformOps()[0]
        t = time.perf_counter()
        op.Set(Gf.Vec3d(0.25, 0.0, 0.0))
        out["edit_s"] = time.perf_counter() - t
        t = time.perf_counter()
        changed = reader._changed[:]
        reader.update()
        out["resync_s"] = time.perf_counter() - t
        out["resync_synced"] = list(delegate.last_synced())
        out["resync_notices"] = [str(p) for p in changed]
        # The commit restarted the running pass on the edited scene: wait for it again.
        t = time.perf_counter()
        wait_pass(rp)
        out["rebuild_s"] = time.perf_counter() - t
    if case in ("camera2m", "edit2m", "edit1mpts"):
        moved = "/Camera" if case == "camera2m" else "/World/Small"
        start = Gf.Vec3d(0.5, 0.5, 3.0) if case == "camera2m" else Gf.Vec3d(0.2, 0.1, 0.2)
        op = UsdGeom.Xformable(stage.GetPrimAtPath(moved)).GetOrderedXformOps()[0]
        updates, passes = [], []
        for k in range(5):
            op.Set(start + Gf.Vec3d(0.01 * (k + 1), 0.0, 0.0))
            t = time.perf_counter()
            reader.update()
            updates.append(time.perf_counter() - t)
            t = time.perf_counter()
            wait_pass(rp)
            passes.append(time.perf_counter() - t)
        what = "camera" if case == "camera2m" else "edit"
        out[what + "_update_s"] = statistics.median(updates)
        out[what + "_pass_s"] = statistics.median(passes)
        out[what + "_synced"] = list(delegate.last_synced())
    reader.close()
    print(json.dumps(out))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.case)
        return
    runs = []
    for _ in range(args.repeats):
        res = subprocess.run([sys.executable, __file__, args.case, "--child"],
                             capture_output=True, text=True)
        if res.returncode != 0:
            sys.stderr.write(res.stderr)
            raise SystemExit("the %s child failed" % args.case)
        line = res.stdout.strip().splitlines()[-1]
        print(line, flush=True)
        runs.append(json.loads(line))
    med = {"case": args.case, "repeats": len(runs), "median": True}
    for k, v in runs[0].items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            med[k] = round(statistics.median(r[k] for r in runs), 4)
    print(json.dumps(med))


if __name__ == "__main__":
    main()
