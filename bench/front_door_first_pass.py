"""Time to the first finished pass of the default stage (`./tide render` with no stage,
640x360), in one fresh process per repeat, from process start:

    .venv/bin/python bench/front_door_first_pass.py [--repeats N] [--threads N]

Phases (seconds since the interpreter started, taken from the same clock):
  import    `tide` + usd-core + the module imported
  load      the default stage opened and read, the delegate committed (what `./tide render`
            reports as "load")
  first     the first progressive pass (1 spp over 640x360) published into the colour buffer
The render is then cancelled. The medians over the repeats are printed last.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def child(threads):
    t0 = time.monotonic()  # just after interpreter start-up; the parent adds its spawn time
    sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))
    from tide import env
    env.prepare()
    from tide import usd_reader
    from tide.default_scene import DEFAULT_SCENE_USDA
    module = env.load_module()
    t_import = time.monotonic()
    stage = usd_reader.stage_from_string(DEFAULT_SCENE_USDA)
    reader = usd_reader.Reader(stage, module.RenderDelegate(),
                               usd_reader.Options(threads=threads))
    reader.load()
    t_load = time.monotonic()
    rp = reader.render_pass()
    target = max(1, reader.sample_target)
    while rp.progress() * target < 1.0 - 1e-6:
        if rp.wait(0.002) and not rp.is_converged():
            raise RuntimeError("render stopped: %s" % rp.error())
    t_first = time.monotonic()
    rp.cancel()
    w, h = reader.resolution
    print(json.dumps({"import_s": t_import - t0, "load_s": t_load - t_import,
                      "first_pass_s": t_first - t_load, "total_s": t_first - t0,
                      "resolution": "%dx%d" % (w, h), "spp_target": target}))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.threads)
        return
    runs = []
    for _ in range(args.repeats):
        cmd = [sys.executable, __file__, "--child"]
        if args.threads:
            cmd += ["--threads", str(args.threads)]
        t = time.monotonic()
        res = subprocess.run(cmd, check=True, capture_output=True, text=True)
        wall = time.monotonic() - t
        r = json.loads(res.stdout.strip().splitlines()[-1])
        r["process_wall_s"] = wall
        print(json.dumps(r), flush=True)
        runs.append(r)
    med = {"repeats": len(runs), "median": True}
    for k in ("import_s", "load_s", "first_pass_s", "total_s", "process_wall_s"):
        med[k] = round(statistics.median(r[k] for r in runs), 3)
    print(json.dumps(med))


if __name__ == "__main__":
    main()
