#!/usr/bin/env python3
"""Equal-time error of a window-lit room with and without its UsdLuxPortalLight.

    .venv/bin/python bench/portals.py [--seconds S] [--rounds R] [--threads N]

The stage is docs/stages/window_room.usda: black walls, a white dome seen only through one
window, an exactly Lambertian floor of albedo 0.5 seen from above. The floor receives only the
dome's direct light through the window, so each pixel's true value is Lambert's formula for the
window polygon (E = ½ Σ θᵢ n·(vᵢ × vᵢ₊₁)/|vᵢ × vᵢ₊₁|, radiance ρE/π), averaged over the pixel.
The variant without the portal deactivates the PortalLight and clears the dome's `portals`
(a session-layer edit written to a temp dir). Both are rendered by `./tide render` with the same
time budget (`--time-budget S`, a huge sample target), alternating in each round; the figure is
each variant's relative RMSE against the formula (the best round of each), and their ratio.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STAGE = os.path.join(ROOT, "docs", "stages", "window_room.usda")


def window_and_view(stage):
    """The window's corners (from the PortalLight), the floor region the orthographic camera
    sees (x and z ranges) and the image size, read from the stage."""
    from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender

    portal = UsdLux.PortalLight(stage.GetPrimAtPath("/World/Window"))
    m = UsdGeom.Xformable(portal).ComputeLocalToWorldTransform(Usd.TimeCode.Default())
    w, h = portal.GetWidthAttr().Get(), portal.GetHeightAttr().Get()
    corners = [np.array(m.Transform(Gf.Vec3d(sx * w / 2, sy * h / 2, 0))) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/World/Cam"))
    assert cam.GetProjectionAttr().Get() == "orthographic"
    half = cam.GetHorizontalApertureAttr().Get() / 10.0 / 2.0     # tenths of a scene unit
    centre = cam.ComputeLocalToWorldTransform(Usd.TimeCode.Default()).ExtractTranslation()
    res = UsdRender.Settings(stage.GetPrimAtPath("/Render/Settings")).GetResolutionAttr().Get()
    return corners, (centre[0] - half, centre[0] + half), (centre[2] - half, centre[2] + half), (res[0], res[1])


def reference(corners, xs, zs, size, albedo=0.5, sub=4):
    """ρE/π per pixel (rows from −z at the top: the camera looks down with its up along −z)."""
    wpx, hpx = size
    x = xs[0] + (np.arange(wpx * sub) + 0.5) / (wpx * sub) * (xs[1] - xs[0])
    z = zs[0] + (np.arange(hpx * sub) + 0.5) / (hpx * sub) * (zs[1] - zs[0])
    px, pz = np.meshgrid(x, z)
    p = np.stack([px, np.zeros_like(px), pz], axis=-1)
    v = [c - p for c in corners]
    v = [a / np.linalg.norm(a, axis=-1, keepdims=True) for a in v]
    e = np.zeros_like(px)
    for i in range(4):
        a, b = v[i], v[(i + 1) % 4]
        c = np.cross(a, b)
        e += np.arccos(np.clip(np.sum(a * b, axis=-1), -1, 1)) * c[..., 1] / np.linalg.norm(c, axis=-1)
    img = albedo / math.pi * 0.5 * np.abs(e)
    return img.reshape(hpx, sub, wpx, sub).mean(axis=(1, 3))


def read_red(path):
    import Imath
    import OpenEXR
    f = OpenEXR.InputFile(path)
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    return np.frombuffer(f.channel("R", Imath.PixelType(Imath.PixelType.FLOAT)), dtype=np.float32).reshape(h, w).astype(np.float64)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=0)
    args = ap.parse_args()
    from pxr import Usd

    stage = Usd.Stage.Open(STAGE)
    corners, xs, zs, size = window_and_view(stage)
    ref = reference(corners, xs, zs, size)
    tmp = tempfile.mkdtemp(prefix="tide_portals_")
    plain = os.path.join(tmp, "no_portal.usda")
    stage.GetPrimAtPath("/World/Window").SetActive(False)
    stage.GetPrimAtPath("/World/Dome").GetRelationship("portals").ClearTargets(True)
    stage.GetRootLayer().Export(plain)
    variants = {"portal": STAGE, "no portal": plain}
    best = {}
    for r in range(args.rounds):
        for name, path in variants.items():
            out = os.path.join(tmp, name.replace(" ", "_") + ".exr")
            cmd = [os.path.join(ROOT, "tide"), "render", path, "-o", out, "--spp", "1000000",
                   "--time-budget", str(args.seconds), "--seed", str(r + 1)]
            if args.threads:
                cmd += ["--threads", str(args.threads)]
            done = subprocess.run(cmd, check=True, capture_output=True, text=True)
            log = done.stdout + done.stderr
            spp = int(re.search(r"(\d+) spp, load", log).group(1))
            rel = math.sqrt(np.mean((read_red(out) - ref) ** 2)) / ref.mean()
            print("round %d  %-9s  %5d spp  relative RMSE %.5f" % (r + 1, name, spp, rel))
            if name not in best or rel < best[name][0]:
                best[name] = (rel, spp)
    print("| variant | spp in %.1f s | relative RMSE |" % args.seconds)
    print("|---|---|---|")
    for name, (rel, spp) in best.items():
        print("| %s | %d | %.5f |" % (name, spp, rel))
    ratio = best["no portal"][0] / best["portal"][0]
    print("equal-time RMSE, no portal / portal: %.1f (relMSE %.0f)" % (ratio, ratio ** 2))


if __name__ == "__main__":
    sys.exit(main())
