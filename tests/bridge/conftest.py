"""Puts cpp-bridge/python on sys.path so `tide._tide` (built by scripts/setup.sh) imports."""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "cpp-bridge" / "python"))
