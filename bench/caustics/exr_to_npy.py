#!/usr/bin/env python3
"""Converts the colour of a Tide EXR to the bench layout: linear float32 H×W×3 `.npy` (rows from
the top, the layout `render_mitsuba.py` writes), and prints the EXR's `tide:*` header as JSON.

    python exr_to_npy.py IN.exr OUT.npy          (needs numpy and OpenEXR: Tide's .venv has both)
"""
import json
import sys

import numpy as np
import OpenEXR


def main():
    src, dst = sys.argv[1], sys.argv[2]
    with OpenEXR.File(src, separate_channels=True) as f:
        ch = f.channels()
        header = {k: (v if isinstance(v, (str, int, float)) else str(v))
                  for k, v in f.header().items() if str(k).startswith("tide:")
                  or k == "renderingColorSpace"}
        rgb = np.stack([np.asarray(ch[c].pixels, np.float32) for c in ("R", "G", "B")], -1)
    np.save(dst, rgb)
    json.dump(header, sys.stdout)


if __name__ == "__main__":
    main()
