"""The `tide` command: render a USD stage to EXR (and a PNG preview), or list what a stage holds.

    tide render [STAGE] [-o OUT.exr] [--settings PRIM] [--camera PATH] [--frame F] [--spp N]
                [--width W] [--threads N] [--seed S] [--integrator {path,caustics}]
                [--time-budget SECONDS] [--max-depth N] [--pixel-filter {gaussian,box,triangle}]
                [--pixel-filter-width W] [--adaptive-threshold T]
    tide info STAGE

Flags override the render settings' attributes (contract: the command line wins):
--spp `tide:samples`, --seed `tide:seed`, --integrator `tide:integrator`, --time-budget
`tide:time:budget` (rendering stops at the sample target or after this many seconds of
rendering, whichever comes first; loading and acceleration-structure building are not counted),
--max-depth `tide:maxDepth`, --pixel-filter `tide:pixelFilter`, --pixel-filter-width
`tide:pixelFilter:width`, --adaptive-threshold `tide:adaptive:threshold`. The EXR header records
the samples per pixel actually reached (`tide:spp`; with adaptive sampling the most any pixel
took, and `tide:adaptive:meanSpp` the mean). A time budget shorter than the first pass ends it
part way: the pixels it did not reach have no samples (alpha 0), and `tide:unsampledPixels`
counts them.

One EXR is written per render product. Products whose own settings (resolution, camera, ...)
agree are rendered together; the others are rendered one after the other, each with the whole
time budget. With -o everything goes into one image at the first product's settings.

Exit status: 0 when the image was written (or the listing printed), even if the stage has
problems: each problem is printed once (`tide render` on stderr as
`tide: problem: PRIM: ATTRIBUTE: MESSAGE`, `tide info` in its listing on stdout) and that prim
or input is dropped or replaced by its documented default (contract section 7); 1 when the
stage could not be opened or rendered at all, or a file could not be written (no file of that
render is left under its final name); 2 for usage errors (bad flags, a --settings or --camera path that names no such prim);
130 when interrupted (Ctrl-C, or SIGTERM as a render farm stops a job: the render is
cancelled and this render's files are not written).
"""
import argparse
import json
import os
import math
import signal
import sys
import time

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    pass


# the renderer's integers are 32-bit: larger flags are usage errors, not stage problems
INT_MAX = 2**31 - 1


def _positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected a positive integer, got %r" % text)
    if not 0 < v <= INT_MAX:
        raise argparse.ArgumentTypeError("expected a positive integer up to %d, got %r"
                                         % (INT_MAX, text))
    return v


def _int(text):
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected an integer, got %r" % text)


def _nonneg_int(text):
    v = _int(text)
    if not 0 <= v <= INT_MAX:
        raise argparse.ArgumentTypeError("expected a non-negative integer up to %d, got %r"
                                         % (INT_MAX, text))
    return v


def _nonneg_float(text):
    v = _float(text)
    if not v >= 0.0 or v == float("inf"):
        raise argparse.ArgumentTypeError("expected a non-negative finite number, got %r" % text)
    return v


def _finite_float(text):
    v = _float(text)
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError("expected a finite number, got %r" % text)
    return v


# usdrecord's and usdview's refinement complexities; the index is the subdivision level
COMPLEXITIES = ("low", "medium", "high", "veryhigh")


def _complexity_arg(parser):
    parser.add_argument("--complexity", "-c", choices=COMPLEXITIES, default="low",
                        help="subdivide meshes that author no tide:subdivision:level this many "
                             "times, as usdrecord's and usdview's complexity does: low 0 (their "
                             "control cage), medium 1, high 2, veryhigh 3 (default: low)")


def _float(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError("expected a number, got %r" % text)


def build_parser():
    p = argparse.ArgumentParser(
        prog="tide", description="Tide: a spectral path tracer for water.",
        epilog="exit status: 0 written (problems in the stage are printed, the rest renders); "
               "1 the stage could not be opened or rendered (no file written); 2 usage error; "
               "130 interrupted")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    r = sub.add_parser("render", help="render a stage (or the built-in pool scene) to EXR")
    r.add_argument("stage", nargs="?", help="USD stage; omitted: a built-in sunlit pool")
    r.add_argument("-o", "--output", metavar="OUT.exr", help="write all AOVs to this EXR")
    r.add_argument("--settings", metavar="PRIM", help="UsdRenderSettings prim to use")
    r.add_argument("--camera", metavar="PATH", help="camera prim (overrides the settings')")
    r.add_argument("--frame", type=_finite_float, metavar="F", help="time code to render")
    r.add_argument("--spp", type=_positive_int, metavar="N", help="samples per pixel")
    r.add_argument("--width", type=_positive_int, metavar="W",
                   help="image width (height keeps the aspect ratio)")
    r.add_argument("--threads", type=_positive_int, metavar="N", help="render threads")
    r.add_argument("--seed", type=_nonneg_int, metavar="S", help="random seed")
    r.add_argument("--integrator", choices=("path", "caustics"),
                   help="light transport (tide:integrator)")
    r.add_argument("--time-budget", type=_nonneg_float, metavar="SECONDS",
                   help="stop rendering after this many seconds if the sample target is not "
                        "reached first (0: no budget; loading is not counted)")
    r.add_argument("--max-depth", type=_nonneg_int, metavar="N",
                   help="maximum path depth (tide:maxDepth)")
    r.add_argument("--pixel-filter", choices=("gaussian", "box", "triangle"),
                   help="pixel reconstruction filter (tide:pixelFilter)")
    r.add_argument("--pixel-filter-width", type=_nonneg_float, metavar="W",
                   help="the filter's full width in pixels (tide:pixelFilter:width; 0: its default)")
    r.add_argument("--adaptive-threshold", type=_nonneg_float, metavar="T",
                   help="stop sampling pixels whose noise is below T (tide:adaptive:threshold; "
                        "0: off)")
    _complexity_arg(r)
    i = sub.add_parser("info", help="list what would be rendered and every problem found")
    i.add_argument("stage", help="USD stage")
    i.add_argument("--settings", metavar="PRIM")
    i.add_argument("--camera", metavar="PATH")
    i.add_argument("--frame", type=_finite_float, metavar="F")
    _complexity_arg(i)
    return p


def _say(msg):
    sys.stderr.write("tide: %s\n" % msg)
    sys.stderr.flush()


def _print_problems(problems):
    for p in problems:
        _say("problem: %s" % (p,))


def _open(args):
    from tide import usd_reader

    if args.stage is None:
        from tide.default_scene import DEFAULT_SCENE_USDA
        return usd_reader.stage_from_string(DEFAULT_SCENE_USDA), "tide"
    if not os.path.exists(args.stage):
        raise RuntimeError("cannot open stage '%s': no such file" % args.stage)
    stage = usd_reader.open_stage(args.stage)
    return stage, os.path.splitext(os.path.basename(args.stage))[0]


def _make_reader(args, stage, delegate, **extra):
    from tide import usd_reader

    opts = usd_reader.Options(settings=args.settings, camera=args.camera, frame=args.frame,
                              refine_level=COMPLEXITIES.index(args.complexity), **extra)
    reader = usd_reader.Reader(stage, delegate, opts)
    try:
        problems = reader.load()
    except LookupError as e:
        raise UsageError(str(e))
    return reader, problems


class Progress:
    """A progress bar on a terminal, plain lines (every 10%) otherwise."""

    def __init__(self, stream=None):
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.last_decile = -1
        self.start = time.monotonic()

    def update(self, fraction, spp_done=None, spp_target=None):
        fraction = max(0.0, min(1.0, fraction))
        elapsed = time.monotonic() - self.start
        spp = "" if spp_target is None else " %d/%d spp" % (spp_done, spp_target)
        if self.tty:
            width = 30
            filled = int(round(width * fraction))
            self.stream.write("\r[%s%s] %3d%%%s %.1fs" % ("#" * filled, "." * (width - filled),
                                                      int(fraction * 100), spp, elapsed))
        else:
            decile = int(fraction * 10)
            if decile == self.last_decile:
                return
            self.last_decile = decile
            self.stream.write("tide: rendering %3d%%%s %.1fs\n" % (decile * 10, spp, elapsed))
        self.stream.flush()

    def clear(self):
        """Clears the bar's line, so that a message can be printed before the next update."""
        if self.tty:
            self.stream.write("\r\033[K")
            self.stream.flush()

    def done(self):
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def _fraction(progress, target):
    """The pass's progress as (fraction, spp done): accepts a fraction or (done, target)."""
    if isinstance(progress, (tuple, list)):
        done, tgt = progress[0], progress[1] if len(progress) > 1 else target
        return (float(done) / tgt if tgt else 0.0), int(done)
    f = float(progress or 0.0)
    # the fraction counts the pass under way in part: whole samples only
    return f, int(f * target + 1e-6)


def _outputs(reader, args, stem):
    """[(file name, [(aov, buffer)], {aov: dataType})] of the current render: its products'
    EXRs, or everything in -o (an AOV in several products takes the first one's dataType)."""
    if args.output:
        types = {}
        for prod in reader.products:
            for aov, t in prod.types.items():
                types.setdefault(aov, t)
        return [(args.output, reader.bindings(every_product=True), types)]
    out = []
    for prod in reader.renders[reader.render_index]:
        i = reader.products.index(prod)
        name = prod.name or ("%s.exr" % stem if i == 0 else "%s_%d.exr" % (stem, i))
        out.append((name, prod.vars, prod.types))
    return out


def cmd_render(args):
    from tide import env

    t0 = time.monotonic()
    stage, stem = _open(args)
    module = env.load_module()
    delegate = module.RenderDelegate()
    reader, problems = _make_reader(args, stage, delegate, spp=args.spp, width=args.width,
                                    seed=args.seed, threads=args.threads,
                                    integrator=args.integrator, time_budget=args.time_budget,
                                    max_depth=args.max_depth, pixel_filter=args.pixel_filter,
                                    pixel_filter_width=args.pixel_filter_width,
                                    adaptive_threshold=args.adaptive_threshold,
                                    single_image=bool(args.output), files_only=True)
    _print_problems(problems)
    for prod in reader.products:
        name = args.output or prod.name
        parent = os.path.dirname(os.path.abspath(name)) if name else "."
        # a product's directory is made where it is missing (as husk does); one that cannot
        # be made stops the render before anything is written
        try:
            os.makedirs(parent, exist_ok=True)
        except OSError as e:
            raise RuntimeError("cannot write '%s': cannot make its directory (%s)"
                               % (name, e.strerror or e))
    count = len(reader.renders)
    for index in range(count):
        if index > 0:
            t0 = time.monotonic()
            _print_problems(reader.select_render(index))
        if count > 1:
            _say("render %d of %d: %s (%dx%d from %s)" % (
                index + 1, count, ", ".join(p.path for p in reader.renders[index]),
                reader.resolution[0], reader.resolution[1], reader.camera_path))
        code = _render_one(reader, delegate, args, _outputs(reader, args, stem),
                           time.monotonic() - t0)
        if code != EXIT_OK:
            return code
    return EXIT_OK


def _render_one(reader, delegate, args, outputs, load_s):
    """Renders the reader's current render to its outputs; prints its summary line."""
    target = max(1, int(reader.sample_target))
    bar = Progress()
    t1 = time.monotonic()
    rp = reader.render_pass()
    try:
        while not rp.is_converged():
            stopped = rp.wait(0.25)
            # what the renderer found while preparing the scene, once it has
            found = reader.commit()
            if found:
                bar.clear()
                _print_problems(found)
            if stopped and not rp.is_converged():
                raise RuntimeError("the render stopped before reaching its target: %s"
                                   % (rp.error() or "cancelled"))
            if rp.is_converged():
                break       # the last line says what was reached
            frac, done = _fraction(rp.progress(), target)
            bar.update(frac, done, target)
        frac, done = _fraction(rp.progress(), target)
        # the samples reached: the target, or fewer where the time budget ended the render
        summary = rp.summary() if hasattr(rp, "summary") else {}
        reached = int(summary["spp"]) if "spp" in summary else max(done, target)
        bar.update(1.0 if rp.is_converged() else frac, reached, target)
    except KeyboardInterrupt:
        rp.cancel()
        bar.done()
        _say("interrupted; this render's files not written")
        return EXIT_INTERRUPTED
    bar.done()
    render_s = time.monotonic() - t1
    summary = rp.summary() if hasattr(rp, "summary") else {}
    # the renderer's own time: sampling only, building the acceleration structures apart
    render_s = float(summary.get("renderSeconds", render_s))
    _print_problems(reader.commit())
    w, h = reader.resolution
    # with adaptive sampling the pixels' mean sample count is below the passes' count
    mean_spp = float(summary["meanSpp"]) if "meanSpp" in summary else None

    def make_header(spp):
        n = mean_spp if mean_spp is not None else spp
        sps = w * h * n / render_s if render_s > 0 else 0.0
        return sps, _header(args, reader, spp, load_s, render_s, sps)

    spp = target
    sps, header = make_header(spp)
    manifest = _prim_id_manifest(reader)
    written = _write(delegate, outputs, header, manifest=manifest)
    # A time budget may stop the render short of its target: the film's own count, which the
    # renderer writes into the header, is the truth; the header is rewritten to agree with it.
    reached = _written(outputs[0][0], "tide:spp")
    if reached is not None and int(reached) != spp:
        spp = int(reached)
        sps, header = make_header(spp)
        _write(delegate, outputs, header, png=False, manifest=manifest)
    adaptive = ""
    if mean_spp is not None:
        # below the passes' count where adaptive sampling stopped pixels, or where the time
        # budget ended a pass part way
        on = _written(outputs[0][0], "tide:adaptive:threshold") is not None
        adaptive = " (%smean %.1f)" % ("adaptive: " if on else "", mean_spp)
    unsampled = int(summary.get("unsampledPixels", "0"))
    if unsampled:
        _say("the time budget ended the first pass: %d of %d pixels have no samples "
             "(alpha 0; `tide:unsampledPixels` in the header)" % (unsampled, w * h))
    build = _written(outputs[0][0], "tide:buildSeconds")
    build = ", build %.2fs" % float(build) if build is not None else ""
    sys.stdout.write("tide: wrote %s (%dx%d, %d spp%s, load %.2fs%s, render %.2fs, %.3g samples/s)\n"
                     % (", ".join(written), w, h, spp, adaptive, load_s, build, render_s, sps))
    if "photonsStored" in summary:
        mib = int(summary.get("photonMapPeakBytes", "0")) / float(1 << 20)
        capped = int(summary.get("photonPassesCapped", "0"))
        connected = int(summary.get("lightConnections", "0"))
        beams = ""
        if "beamsPerQuery" in summary:
            beams = ", beams met per query %s, share kept %.3g" % (
                summary["beamsPerQuery"], float(summary.get("beamShare", "1")))
        sys.stdout.write("tide: caustics: %s photon passes, %s photons shot, %s stored, "
                         "peak photon map %.1f MiB%s%s%s, photon tracing %ss\n"
                         % (summary["photonPasses"], summary["photonsEmitted"],
                            summary["photonsStored"], mib,
                            " (%d passes cut to the memory budget)" % capped if capped else "",
                            ", %d photon stretches connected to the camera" % connected
                            if connected else "", beams,
                            summary.get("photonSeconds", "?")))
    return EXIT_OK


def _written(path, key):
    """A value of the header the renderer wrote (it records what it used), or None."""
    from tide import exr_header

    try:
        return exr_header.read_header(path).get(key)
    except (OSError, ValueError):
        return None


def _header(args, reader, spp, load_s, render_s, sps):
    header = {
        "tide:stage": args.stage or "<built-in pool>",
        "tide:camera": reader.camera_path,
        "tide:settings": reader.settings_path,
        "tide:frame": "%g" % reader.frame,
        "tide:spp": str(spp),
        "tide:loadSeconds": "%.3f" % load_s,
        "tide:renderSeconds": "%.6f" % render_s,
        "tide:samplesPerSecond": "%.0f" % sps,
        "tide:problems": str(len(reader.problems)),
    }
    sent = reader.sent().get(reader.settings_path)
    if sent:
        for key in ("tide:integrator", "tide:seed", "tide:maxDepth", "tide:time:budget",
                    "renderingColorSpace"):
            if key in sent[1]:
                header[key] = str(sent[1][key][0][1][1])
    return header


def _prim_id_manifest(reader):
    """The `tide:primIdManifest` header value: a JSON object from each rendered prim's path to
    the id its pixels carry in the `primId` AOV (in id order)."""
    ids = []
    for path, (_, values) in reader.sent().items():
        value = values.get("primId")
        if value:
            ids.append((int(value[0][1][1]), path))
    return json.dumps({path: i for i, path in sorted(ids)}, separators=(",", ":"))


def _staging(name):
    """A temporary name beside `name` (same directory and extension) to write it under."""
    d, base = os.path.split(name)
    stem, ext = os.path.splitext(base)
    return os.path.join(d, ".%s.tide%d%s" % (stem, os.getpid(), ext))


def _write(delegate, outputs, header, png=True, manifest=None):
    """Writes every file of the render under a temporary name beside its own, then gives them
    their names: a file that cannot be written leaves none of this render's files behind. A
    file with the `primId` AOV gets `manifest` too, as `tide:primIdManifest`."""
    staged = []
    try:
        for name, vars_, types in outputs:
            tmp = _staging(name)
            staged.append((tmp, name))
            own = header
            if manifest is not None and any(aov == "primId" for aov, _ in vars_):
                own = dict(header, **{"tide:primIdManifest": manifest})
            delegate.write_exr(tmp, [(aov, aov, types.get(aov, "")) for aov, _ in vars_], own)
            color = [buf for aov, buf in vars_ if aov == "color"]
            png_name = os.path.splitext(name)[0] + ".png"
            if os.path.abspath(png_name) == os.path.abspath(name):
                png_name = name + ".png"     # a product named *.png keeps its EXR
            if color and png:
                # the colour space the render used (an unknown one authored was replaced)
                space = _written(tmp, "renderingColorSpace") or "lin_rec709"
                tmp_png = _staging(png_name)
                staged.append((tmp_png, png_name))
                delegate.write_preview_png(tmp_png, color[0], space, "Standard")
        for _, final in staged:
            if os.path.isdir(final):
                raise OSError("%s: is a directory" % final)
        for tmp, final in staged:
            os.replace(tmp, final)
    except BaseException:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    return [final for _, final in staged]


def cmd_info(args):
    from tide import env
    from tide import usd_reader

    stage, _ = _open(args)
    try:
        module = env.load_module()
        note = ""
    except RuntimeError:
        module = env.load_module(fake=True)
        note = " (the renderer module is not built: only the reader's checks ran)"
    reader, problems = _make_reader(args, stage, module.RenderDelegate())
    # the renderer's own checks (validation, media, lights, volumes), as a render would run them
    reader.check()
    out = sys.stdout
    w, h = reader.resolution
    out.write("stage: %s\n" % args.stage)
    out.write("settings: %s  camera: %s  resolution: %dx%d  frame: %g  samples: %d\n"
              % (reader.settings_path, reader.camera_path, w, h, reader.frame,
                 reader.sample_target))
    if len(reader.renders) > 1:
        out.write("render 1: %s  (products whose settings differ are rendered apart)\n"
                  % ", ".join(p.name for p in reader.renders[0]))
    for prod in reader.products:
        out.write("product: %s  vars: %s\n" % (prod.name or "<default>",
                                              ", ".join(a for a, _ in prod.vars)))
    sent = reader.sent()
    if len(reader.renders) > 1:
        # products whose settings differ are rendered apart: list each render's own
        for index in range(1, len(reader.renders)):
            reader.select_render(index)
            rw, rh = reader.resolution
            out.write("render %d: %s  camera: %s  resolution: %dx%d  samples: %d\n"
                      % (index + 1, ", ".join(p.name for p in reader.renders[index]),
                         reader.camera_path, rw, rh, reader.sample_target))
        reader.select_render(0)
    for path in sorted(sent):
        type_name, values = sent[path]
        if type_name == "renderBuffer":
            continue
        extra = ""
        if "instanceTransforms" in values:
            n = usd_reader.rows(values["instanceTransforms"][0][1])
            extra += "  instances: %d" % n
        if "material" in values and values["material"][0][1][1]:
            extra += "  material: %s" % values["material"][0][1][1]
        if "transform" in values and len(values["transform"]) > 1:
            extra += "  motion samples: %d" % len(values["transform"])
        if "portals" in values:
            extra += "  portals: %s" % ", ".join(values["portals"][0][1][1])
        if "apiSchemas" in values:
            extra += "  as: %s" % ", ".join(values["apiSchemas"][0][1][1])
        out.write("%-14s %s%s\n" % (type_name, path, extra))
    out.write("problems: %d%s\n" % (len(reader.problems), note))
    for p in reader.problems:
        out.write("  %s\n" % (p,))
    return EXIT_OK


def _terminate(signum, frame):
    # SIGTERM stops the command as Ctrl-C does: the render is cancelled, nothing half-written
    raise KeyboardInterrupt


def main(argv=None):
    if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _terminate)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:
        return int(e.code or 0) if e.code not in (None, 0) else 0
    try:
        if args.command == "render":
            return cmd_render(args)
        return cmd_info(args)
    except UsageError as e:
        _say("error: %s" % e)
        return EXIT_USAGE
    except KeyboardInterrupt:
        _say("interrupted; nothing written")
        return EXIT_INTERRUPTED
    except Exception as e:  # the stage could not be opened or rendered at all
        _say("error: %s" % (str(e).strip() or type(e).__name__))
        return EXIT_FAIL


if __name__ == "__main__":
    sys.exit(main())
