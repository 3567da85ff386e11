#!/usr/bin/env python3
"""Cost of Tide's spectral water medium and Hošek–Wilkie sky against a constant RGB medium and a
constant dome, on the same stage at the same samples.

    .venv/bin/python bench/water_models.py [STAGE.usda] [--rounds R] [--spp LO,HI] [--width W]
                                           [--threads N] [--cpu] [--matched-rgb [--water-depth H]]

STAGE (default docs/stages/clear_ib.usda) must bind a TideMedium and carry a DomeLight with
TideSkyAPI. Four variants are written to a temp dir with usd-core:

    spectral+sky   the stage as it is (Jerlov or bio-optical medium, Hošek–Wilkie sky, physical sun)
    rgb+sky        every TideMedium's jerlovType/bio-optical inputs cleared and a constant RGB
                   absorption/scattering set instead (its phase function kept): clear blue
                   water, or with --matched-rgb the stage's own water averaged over its column
                   and each channel's band, so that both media scatter about as often and the
                   difference is the model's cost rather than a different light transport
    spectral+dome  the sky's TideSkyAPI removed: a constant-colour dome, and the sun a plain
                   DistantLight with an authored intensity
    rgb+dome       both

Each variant is rendered by `./tide render` in a fresh process at LO and at HI spp, the variants
alternating within each round. The render time a process prints includes set-up that does not
depend on the sample count (building the acceleration structures), so the time per sample is
the marginal one, (t(HI) - t(LO)) / (HI - LO) per pixel sample, from the best (smallest) t of the
rounds at each count: other work on a shared machine only ever adds time. With --cpu the time is
the process's CPU time instead (user + system, start-up included, which cancels in the
difference), which load from other processes inflates far less. Ratios are against rgb+dome.
"""
import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))

RGB_ABSORPTION = (0.42, 0.065, 0.022)   # docs/stages/ocean.usda's clear blue water
RGB_SCATTERING = (0.02, 0.03, 0.045)
SPECTRAL_INPUTS = ("jerlovType", "chlorophyll", "cdom", "spm", "profileDepth", "profileWidth",
                   "profilePeak")


def matched_rgb(stage_path, water_depth=None):
    """The constant RGB (absorption, scattering) closest to the stage's TideMedium: its
    bio-optical coefficients averaged over the water column and each channel's band, from
    `core/examples/water_rgb.rs`. The depth is the TideOcean's `depth` unless given."""
    from pxr import Usd, UsdShade

    stage = Usd.Stage.Open(stage_path)
    args = []
    salinity = 35.0
    for prim in stage.Traverse():
        if prim.GetTypeName() == "TideOcean" and water_depth is None:
            d = prim.GetAttribute("depth").Get()
            if d:
                water_depth = float(d)
        if not prim.IsA(UsdShade.Shader):
            continue
        sh = UsdShade.Shader(prim)
        ident = sh.GetIdAttr().Get()
        get = lambda name, default: (sh.GetInput(name).Get() if sh.GetInput(name)
                                     and sh.GetInput(name).Get() is not None else default)
        if ident == "TideWater":
            salinity = float(get("salinity", 35.0))
        elif ident == "TideMedium" and not args:
            if get("jerlovType", ""):
                args += ["--jerlov", str(get("jerlovType", ""))]
            for name in ("chlorophyll", "cdom", "spm"):
                args += ["--" + name, "%g" % float(get(name, 0.0))]
            peak, width = float(get("profilePeak", 0.0)), float(get("profileWidth", 0.0))
            if peak > 0 and width > 0:
                args += ["--profile", "%g,%g,%g" % (float(get("profileDepth", 0.0)), width, peak)]
    if not args or not water_depth:
        sys.exit("%s: --matched-rgb needs a TideMedium and a water depth (a TideOcean's depth, "
                 "or --water-depth)" % stage_path)
    cmd = ["cargo", "run", "-q", "--release", "-p", "tide-core", "--example", "water_rgb", "--",
           "--depth", "%g" % water_depth, "--salinity", "%g" % salinity] + args
    res = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), res.stderr))
    vals = {line.split()[0]: tuple(float(x) for x in line.split()[1:])
            for line in res.stdout.splitlines() if line.strip()}
    return vals["absorption"], vals["scattering"], " ".join(cmd)


def make_variants(stage_path, out_dir, rgb=(RGB_ABSORPTION, RGB_SCATTERING)):
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
                            Gf.Vec3f(*rgb[0]))
                        sh.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(
                            Gf.Vec3f(*rgb[1]))
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


def render(stage, out_dir, spp, width, threads=None, cpu=False):
    """The render time `tide render` prints, or with `cpu` the CPU time (user + system) of the
    whole process, which other load on the machine changes far less than the wall clock."""
    out = os.path.join(out_dir, "out.exr")
    cmd = [os.path.join(ROOT, "tide"), "render", stage, "-o", out, "--spp", str(spp),
           "--width", str(width)]
    if threads:
        cmd += ["--threads", str(threads)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    res = subprocess.run(cmd, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    m = re.search(r"render ([0-9.]+)s", res.stdout)
    if res.returncode != 0 or not m:
        sys.exit("failed: %s\n%s%s" % (" ".join(cmd), res.stdout, res.stderr))
    if cpu:
        return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return float(m.group(1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("stage", nargs="?", default=os.path.join(ROOT, "docs/stages/clear_ib.usda"))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--spp", default="2,10", help="LO,HI samples per pixel")
    ap.add_argument("--width", type=int, default=240)
    ap.add_argument("--threads", type=int, default=None, help="passed to tide render")
    ap.add_argument("--cpu", action="store_true",
                    help="time by the process's CPU time instead of its printed render time")
    ap.add_argument("--matched-rgb", action="store_true",
                    help="the constant RGB medium matches the TideMedium's coefficients averaged "
                         "over the water column (core/examples/water_rgb.rs) instead of clear "
                         "blue water")
    ap.add_argument("--water-depth", type=float, default=None,
                    help="water column for --matched-rgb (default: the TideOcean's depth)")
    args = ap.parse_args()
    lo, hi = (int(x) for x in args.spp.split(","))
    with tempfile.TemporaryDirectory(prefix="tide_water_models_") as tmp:
        rgb = (RGB_ABSORPTION, RGB_SCATTERING)
        if args.matched_rgb:
            a, b, cmd = matched_rgb(os.path.abspath(args.stage), args.water_depth)
            rgb = (a, b)
            print("matched RGB medium (%s): absorption %s, scattering %s" % (cmd, a, b))
        variants = make_variants(os.path.abspath(args.stage), tmp, rgb)
        order = ["spectral+sky", "rgb+sky", "spectral+dome", "rgb+dome"]
        best = {(v, s): float("inf") for v in order for s in (lo, hi)}
        for r in range(args.rounds):
            # alternate the variants, and rotate which goes first each round
            rot = order[r % 4:] + order[:r % 4]
            for s in (lo, hi):
                for v in rot:
                    t = render(variants[v], tmp, s, args.width, args.threads, args.cpu)
                    best[(v, s)] = min(best[(v, s)], t)
                    print("round %d  %-14s %3d spp  %.3f s" % (r + 1, v, s, t), flush=True)
        h = round(args.width * 9 / 16)
        px = args.width * h
        print()
        print("%s, %dx%d, %s spp, best of %d alternating rounds, %s%s"
              % (os.path.relpath(args.stage, ROOT), args.width, h, args.spp, args.rounds,
                 "CPU time" if args.cpu else "render time",
                 ", %d thread(s)" % args.threads if args.threads else ""))
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
