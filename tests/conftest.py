"""Shared pytest setup: puts the `tide` package on sys.path and makes usd-core see the
tideSchemas plugin and the TideWater/TideMedium shader definitions before pxr is imported."""
import os
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(ROOT, "cpp-bridge", "python"))

from tide import env  # noqa: E402

env.prepare()
