"""Writes docs/stages/fog_bank.vdb, the density grid of fog_bank.usda: a 48 x 20 x 32 bank of
fog, 0.1 wide voxels, dense at its core and thinning towards a ragged top.

Run from the repository root: PYTHONPATH=cpp-bridge/python .venv/bin/python docs/stages/fog_bank.py
"""
import os

import numpy as np

from tide import env

DIMS = (48, 20, 32)
VOXEL = 0.1


def density():
    x, y, z = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in DIMS), indexing="ij")
    u = (x - DIMS[0] / 2) / (DIMS[0] / 2)
    v = y / DIMS[1]
    w = (z - DIMS[2] / 2) / (DIMS[2] / 2)
    # a ragged top: the height the fog reaches wanders with x and z
    top = 0.65 + 0.2 * np.sin(3.1 * u + 0.7) * np.cos(2.3 * w) + 0.1 * np.sin(7.3 * u * w)
    d = np.clip((top - v) / 0.25, 0.0, 1.0) * np.clip(1.0 - u * u - w * w, 0.0, 1.0)
    d *= 1.0 + 0.3 * np.sin(5.0 * u) * np.sin(6.0 * v + 1.0) * np.sin(4.0 * w)
    # x fastest, as write_vdb takes it
    return np.clip(d, 0.0, None).astype(np.float32).transpose(2, 1, 0).ravel()


def main():
    module = env.load_module(fake=False)
    here = os.path.dirname(os.path.abspath(__file__))
    origin = (-DIMS[0] * VOXEL / 2, 0.0, -DIMS[2] * VOXEL / 2)
    module.write_vdb(os.path.join(here, "fog_bank.vdb"),
                     [("density", "float", DIMS, density().tobytes(), VOXEL, origin, (0, 0, 0))])


if __name__ == "__main__":
    main()
