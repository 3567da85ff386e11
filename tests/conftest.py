"""Shared pytest setup: puts the `tide` package on sys.path (and, after everything else, this
folder, for `images`) and makes usd-core see the tideSchemas plugin and the TideWater/TideMedium
shader definitions before pxr is imported."""
import os
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))
sys.path.append(os.path.dirname(os.path.abspath(__file__)))

from tide import env  # noqa: E402

env.prepare()
