"""Helpers shared by the front-door benchmarks that measure a checkout's reader and module."""
import os
import sys

THIS_CHECKOUT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def tide_from(root):
    """(usd_reader, the extension module) of the checkout at `root`, with USD set up as the
    `tide` command sets it up."""
    sys.path.insert(0, os.path.join(root, "cpp-bridge", "python"))
    from tide import env
    env.prepare()
    from tide import usd_reader
    return usd_reader, env.load_module()


def load_timed(usd_reader, module, stage):
    """Reads `stage` into a new delegate and commits it: (reader, the reader's seconds, the
    commit's seconds, the problems)."""
    import time
    t0 = time.perf_counter()
    reader = usd_reader.Reader(stage, module.RenderDelegate(), usd_reader.Options())
    reader.populate()
    t1 = time.perf_counter()
    problems = reader.commit()
    return reader, t1 - t0, time.perf_counter() - t1, problems


def peak_mib():
    """The process's peak resident memory so far (MiB)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return 0.0
