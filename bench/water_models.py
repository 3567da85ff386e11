#!/usr/bin/env python3
"""Cost of Tide's spectral water medium and Hošek–Wilkie sky against a constant RGB medium and a
constant dome, on the same stage at the same samples.

    .venv/bin/python bench/water_models.py [STAGE.usda] [--rounds R] [--spp LO,HI] [--width W]

STAGE (default docs/stages/clear_ib.usda) must bind a TideMedium and carry a DomeLight with
TideSkyAPI. Four variants are written to a temp dir with usd-core:

    spectral+sky   the stage as it is (Jerlov or bio-optical medium, Hošek–Wilkie sky, physical sun)
    rgb+sky        every TideMedium's jerlovType/bio-optical inputs cleared and a constant RGB
                   absorption/scattering set instead (its phase function kept)
    spectral+dome  the sky's TideSkyAPI removed: a constant-colour dome, and the sun a plain
                   DistantLight with an authored intensity
    rgb+dome       both

Each variant is rendered by `./tide render` in a fresh process at LO and at HI spp, the variants
alternating within each round. The render time a process prints includes set-up that does not
depend on the sample count (building the acceleration structures), so the time per sample is
the marginal one, (t(HI) - t(LO)) / (HI - LO) per pixel sample, from the best (smallest) t of the
rounds at each count: other work on a shared machine only ever adds time. Ratios are against
rgb+dome.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))

RGB_ABSORPTION = (0.42, 0.065, 0.022)   # docs/stages/ocean.usda's clear blue water
RGB_SCATTERING = (0.02, 0.03, 0.045)
SPECTRAL_INPUTS = ("jerlovType", "chlorophyll", "cdom", "spm", "profileDepth", "profileWidth",
                   "profilePeak")


def make_variants(stage_path, out_dir):
    from pxr import Gf, Sdf, Usd, UsdShade

    paths = {}
    for medium in ("spectral", "rgb"):
        for sky in ("sky", "dome"):
            # a fresh anonymous copy each time: edits to a stage opened by path would change the
            # shared, cached layer that the next variant opens
            stage = Usd.Stage.Open(Sdf.Layer.OpenAsAnonymous(stage_path))
            n_media = n_skies = 0
            for prim in stage.Traverse():
                if prim.IsA(UsdShade.Shader):
                    sh = UsdShade.Shader(prim)
                    if sh.GetIdAttr().Get() != "TideMedium":
                        continue
                    n_media += 1
                    if medium == "rgb":
                        for name in SPECTRAL_INPUTS:
                            prim.RemoveProperty("inputs:" + name)
                        sh.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(
                            Gf.Vec3f(*RGB_ABSORPTION))
                        sh.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(
                            Gf.Vec3f(*RGB_SCATTERING))
                elif prim.GetTypeName() == "DomeLight" and prim.HasRelationship("tide:sky:sun"):
                    n_skies += 1
                    if sky == "dome":
                        sun = prim.GetRelationship("tide:sky:sun").GetTargets()
                        prim.RemoveAppliedSchema("TideSkyAPI")
                        for prop in prim.GetPropertyNames():
                            if prop.startswith("tide:sky:"):
                                prim.RemoveProperty(prop)
                        prim.CreateAttribute("inputs:color", Sdf.ValueTypeNames.Color3f).Set(
                            Gf.Vec3f(0.45, 0.62, 0.9))
                        prim.CreateAttribute("inputs:intensity", Sdf.ValueTypeNames.Float).Set(
                            8000.0)
                        for s in sun:
                            stage.GetPrimAtPath(s).CreateAttribute(
                                "inputs:intensity", Sdf.ValueTypeNames.Float).Set(1.0e5)
            if not n_media or not n_skies:
                sys.exit("%s: needs a TideMedium and a TideSkyAPI dome (found %d, %d)"
                         % (stage_path, n_media, n_skies))
            name = "%s+%s" % (medium, sky)
            path = os.path.join(out_dir, name.replace("+", "_") + ".usda")
            stage.Export(path)
            paths[name] = path
    return paths


def render(stage, out_dir, spp, width):
    out = os.path.join(out_dir, "out.exr")
    cmd = [os.path.join(ROOT, "tide"), "render", stage, "-o", out, "--spp", str(spp),
           "--width", str(width)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"render ([0-9.]+)s", res.stdout)
    if res.returncode != 0 or not m:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), res.stdout, res.stderr))
    return float(m.group(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("stage", nargs="?", default=os.path.join(ROOT, "docs/stages/clear_ib.usda"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--spp", default="2,10", help="LO,HI samples per pixel")
    ap.add_argument("--width", type=int, default=240)
    args = ap.parse_args()
    lo, hi = (int(x) for x in args.spp.split(","))
    with tempfile.TemporaryDirectory(prefix="tide_water_models_") as tmp:
        variants = make_variants(os.path.abspath(args.stage), tmp)
        order = ["spectral+sky", "rgb+sky", "spectral+dome", "rgb+dome"]
        best = {(v, s): float("inf") for v in order for s in (lo, hi)}
        for r in range(args.rounds):
            # alternate the variants, and rotate which goes first each round
            rot = order[r % 4:] + order[:r % 4]
            for s in (lo, hi):
                for v in rot:
                    t = render(variants[v], tmp, s, args.width)
                    best[(v, s)] = min(best[(v, s)], t)
                    print("round %d  %-14s %3d spp  %.3f s" % (r + 1, v, s, t), flush=True)
        h = round(args.width * 9 / 16)
        px = args.width * h
        print()
        print("%s, %dx%d, %s spp, best of %d alternating rounds"
              % (os.path.relpath(args.stage, ROOT), args.width, h, args.spp, args.rounds))
        print("| variant | t(%d spp) s | t(%d spp) s | ns per pixel sample | vs rgb+dome |" % (lo, hi))
        print("|---|---|---|---|---|")
        per = {v: (best[(v, hi)] - best[(v, lo)]) / ((hi - lo) * px) * 1e9 for v in order}
        for v in order:
            print("| %s | %.3f | %.3f | %.0f | %.3f |"
                  % (v, best[(v, lo)], best[(v, hi)], per[v], per[v] / per["rgb+dome"]))
        print("spectral medium alone (spectral+dome / rgb+dome): %.3f"
              % (per["spectral+dome"] / per["rgb+dome"]))
        print("sky alone (rgb+sky / rgb+dome): %.3f" % (per["rgb+sky"] / per["rgb+dome"]))
        print("both (spectral+sky / rgb+dome): %.3f" % (per["spectral+sky"] / per["rgb+dome"]))


if __name__ == "__main__":
    main()
