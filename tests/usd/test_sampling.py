"""Pixel filters and adaptive sampling through USD render settings (`tide:pixelFilter`,
`tide:pixelFilter:width`, `tide:adaptive:threshold`), checked against the filters' own
integrals computed here.

The edge stage: a black card covers x < 0 in front of a white dome, seen by a camera on the
axis, so the card's edge falls exactly on the boundary between the two middle columns. A pixel
whose centre lies d pixels from the edge on the dark side sees the dome with the probability
that its filter's offset exceeds d: the filter's tail mass beyond d.
"""
import math
import os
import subprocess

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

from conftest import ROOT, bind, camera, lambert_material, render, settings

W, H, SPP = 16, 16, 256


def _phi(x):
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


def _tail(kind, width, d):
    """P(offset > d) for the filter `kind` of full width `width` (pixels)."""
    r = width / 2.0
    if d >= r:
        return 0.0
    if kind == "box":
        return (r - d) / width
    if kind == "triangle":
        return (r - d) ** 2 / (2.0 * r * r)
    sigma = width / 6.0
    cut = _phi(-3.0)
    return (_phi(-d / sigma) - cut) / (1.0 - 2.0 * cut)


def _edge_stage(stage):
    camera(stage, focal=50.0, aperture=(36.0, 36.0))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    card = UsdGeom.Mesh.Define(stage, "/Card")
    card.CreatePointsAttr([(-100, -100, -10), (0, -100, -10), (0, 100, -10), (-100, 100, -10)])
    card.CreateFaceVertexCountsAttr([4])
    card.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    card.CreateDoubleSidedAttr(True)
    bind(card.GetPrim(), lambert_material(stage, "/Looks/Black", (0, 0, 0)))


def _column_means(img):
    y = 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]
    return y.astype(np.float64).mean(axis=0)


@pytest.mark.parametrize("kind,width", [("gaussian", 0.0), ("box", 0.0), ("triangle", 0.0),
                                        ("gaussian", 4.5), ("box", 2.0)])
def test_an_edge_is_spread_by_the_filter_named_in_the_settings(renderer, stage, kind, width):
    _edge_stage(stage)
    s = settings(stage, res=(W, H), samples=SPP, integrator="path", pixelFilter=kind,
                 pixelFilter__width=width)
    assert s.GetPrim().GetAttribute("tide:pixelFilter").Get() == kind
    cols = _column_means(render(renderer, stage)["color"])
    full = {"gaussian": 3.0, "box": 1.0, "triangle": 2.0}[kind] if width == 0 else width
    dome = cols[-1]
    assert dome == pytest.approx(1.0, abs=0.05)
    n = H * SPP
    for c in range(W):
        d = abs(c + 0.5 - W / 2)          # distance of the column centre from the edge
        p = _tail(kind, full, d)
        expect = p if c < W / 2 else 1.0 - p
        # each column is the mean of H·SPP Bernoulli(p) draws times the dome's value; the
        # dome's own colour noise (hero wavelengths) is below 1% per pixel at 256 spp
        sigma = math.sqrt(max(p * (1 - p), 1e-4) / n)
        assert abs(cols[c] / dome - expect) < 5 * sigma + 0.01 * expect + 1e-3, (c, cols[c], expect)


def test_the_filters_differ_where_the_test_can_tell():
    # the assertions above separate the filters: their tails one half pixel from the edge
    # differ by far more than the 5σ + 1% tolerance (σ ≈ 0.006 at 4096 draws)
    g, t, b = _tail("gaussian", 3.0, 0.5), _tail("triangle", 2.0, 0.5), _tail("box", 1.0, 0.5)
    assert (g, b) == (pytest.approx(0.1577, abs=1e-4), 0.0)
    assert t == 0.125 and g - t > 0.03 + 0.01 * g


def test_adaptive_sampling_ends_a_quiet_render_early(renderer, stage, tmp_path):
    """All-dome stage: every pixel's noise drops below the threshold long before 4096 samples,
    so the render stops; the EXR header says how many samples it took."""
    camera(stage, focal=50.0, aperture=(36.0, 36.0))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    settings(stage, res=(8, 8), samples=4096, integrator="path", adaptive__threshold=0.05)
    path = str(tmp_path / "sky.usda")
    stage.GetRootLayer().Export(path)
    exr = str(tmp_path / "sky.exr")
    env = dict(os.environ)
    out = subprocess.run([os.path.join(ROOT, "tide"), "render", path, "-o", exr],
                         cwd=str(tmp_path), env=env, capture_output=True, text=True,
                         stdin=subprocess.DEVNULL, timeout=120)
    assert out.returncode == 0, out.stderr
    from tide import exr_header
    h = exr_header.read_header(exr)
    spp = int(h["tide:spp"])
    assert 31 <= spp < 4096, h
    assert float(h["tide:adaptive:threshold"]) == pytest.approx(0.05)
    assert float(h["tide:adaptive:meanSpp"]) <= spp
    assert (h["tide:pixelFilter"], h["tide:pixelFilter:width"]) == ("box", "1")
    # the command-line flags override the settings
    exr2 = str(tmp_path / "sky2.exr")
    out = subprocess.run([os.path.join(ROOT, "tide"), "render", path, "-o", exr2,
                          "--adaptive-threshold", "0", "--spp", "40", "--pixel-filter", "gaussian"],
                         cwd=str(tmp_path), env=env, capture_output=True, text=True,
                         stdin=subprocess.DEVNULL, timeout=120)
    assert out.returncode == 0, out.stderr
    h2 = exr_header.read_header(exr2)
    assert h2["tide:spp"] == "40" and "tide:adaptive:meanSpp" not in h2
    assert (h2["tide:pixelFilter"], h2["tide:pixelFilter:width"]) == ("gaussian", "3")


def test_bad_filter_settings_are_named_and_the_image_renders(renderer, stage):
    from conftest import load
    from tide import env
    _edge_stage(stage)
    settings(stage, res=(W, H), samples=4, integrator="path", pixelFilter="mitchell",
             pixelFilter__width=-1.0, adaptive__threshold=-0.5)
    module = env.load_module(fake=False)
    d = module.RenderDelegate()
    reader, problems = load(stage, d)
    named = {(p.prim, p.attribute) for p in list(problems) + list(reader.commit())}
    assert ("/Render/Settings", "tide:pixelFilter") in named, named
    assert ("/Render/Settings", "tide:pixelFilter:width") in named, named
    assert ("/Render/Settings", "tide:adaptive:threshold") in named, named
    img = render(renderer, stage)["color"]
    assert np.isfinite(img).all() and img[..., :3].max() > 0.5
