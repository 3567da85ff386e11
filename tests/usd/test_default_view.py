"""A stage without a camera is rendered as usdrecord renders it: through a default 50 mm camera
that frames the bounds of the stage (looking down -Z; down +Y on a Z-up stage). The images
are checked against spheres projected independently through that camera, as USD describes it
(GfCamera's defaults, the settings' aspect-ratio conform policy)."""
import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom

from conftest import camera, floats, load, matrix, render, settings
from tide import usd_reader

FOCAL, H_AP, V_AP = 50.0, 20.955, 15.2908


def _spheres(stage, spheres):
    for i, (centre, radius) in enumerate(spheres):
        s = UsdGeom.Sphere.Define(stage, "/World/S%d" % i)
        s.CreateRadiusAttr(radius)
        s.AddTranslateOp().Set(Gf.Vec3d(*centre))


def _no_camera_settings(stage, res):
    s = settings(stage, res=res, samples=4)
    s.GetCameraRel().ClearTargets(True)
    return s


def _expected_eye(spheres, z_up):
    """Where usdrecord's default camera stands for the bounds of `spheres`, and its axes."""
    lo = np.min([np.asarray(c) - r for c, r in spheres], axis=0)
    hi = np.max([np.asarray(c) + r for c, r in spheres], axis=0)
    centre, size = (lo + hi) / 2, hi - lo
    if z_up:
        across, along = math.hypot(size[0], size[2]), size[1]
        forward, up = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    else:
        across, along = math.hypot(size[0], size[1]), size[2]
        forward, up = np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0])
    distance = 0.5 * across / (0.5 * H_AP / FOCAL) + 0.5 * along
    return centre - forward * distance, forward, up


def _coverage(spheres, z_up, w, h, offsets, hit_only=None):
    """Per pixel, how many of the rays through the pixel's centre moved by `offsets` (in
    pixels) hit a sphere (of `hit_only` where given); the apertures expanded to the image's
    aspect (expandAperture)."""
    eye, forward, up = _expected_eye(spheres, z_up)
    right = np.cross(forward, up)
    ha, va = H_AP, V_AP
    if w / h > ha / va:
        ha = va * w / h
    else:
        va = ha * h / w
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    count = np.zeros((h, w), dtype=int)
    for dx, dy in offsets:
        u = ((xs + 0.5 + dx) / w - 0.5) * ha / FOCAL
        v = (0.5 - (ys + 0.5 + dy) / h) * va / FOCAL
        d = forward + u[..., None] * right + v[..., None] * up
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        hit = np.zeros((h, w), dtype=bool)
        for c, r in (spheres if hit_only is None else hit_only):
            oc = eye - np.asarray(c, dtype=np.float64)
            b = d @ oc
            disc = b * b - (oc @ oc - r * r)
            hit |= (disc > 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0)
        count += hit
    return count


SCENES = {
    # a large sphere and a small one to its right (+X), the small one raised
    "y_up": ([((0.0, 0.0, 0.0), 1.0), ((3.0, 0.6, 0.0), 0.5)], False),
    # the same laid out on a Z-up stage: +X right, +Z up in the image
    "z_up": ([((0.0, 0.0, 0.0), 1.0), ((3.0, 0.0, 0.6), 0.5)], True),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_a_stage_without_a_camera_is_seen_framed_by_a_default_one(renderer, name):
    spheres, z_up = SCENES[name]
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z if z_up else UsdGeom.Tokens.y)
    _spheres(stage, spheres)
    w, h = 96, 54
    _no_camera_settings(stage, (w, h))
    problems = []
    img = render(renderer, stage, problems)["color"]
    assert [(p.prim, p.attribute) for p in problems] == [("/Render/Settings", "camera")]
    alpha = img[..., 3]
    grid = [(dx, dy) for dx in (-1.0, 0.0, 1.0) for dy in (-1.0, 0.0, 1.0)]
    count = _coverage(spheres, z_up, w, h, grid)
    inside, outside = count == len(grid), count == 0
    # both spheres are in view, whole, and the bounds fill the width of the view
    assert inside.sum() > 150 and outside.sum() > 1500
    assert not count[:, 0].any() and not count[:, -1].any()
    assert not count[0].any() and not count[-1].any()
    assert np.all(alpha[inside] > 0.999), np.argwhere(inside & (alpha <= 0.999))[:5]
    assert np.all(alpha[outside] < 0.001), np.argwhere(outside & (alpha >= 0.001))[:5]
    # the small sphere: right of the big one, and above its centre line
    big, small = (np.argwhere((alpha > 0.5) & (_coverage(spheres, z_up, w, h, [(0.0, 0.0)],
                                                         spheres[i:i + 1]) > 0))
                  for i in (0, 1))
    assert len(big) > 4 * len(small) > 0
    assert small[:, 1].min() > big[:, 1].max() and small[:, 0].mean() < big[:, 0].mean() - 1


def test_the_default_camera_is_sent_and_given_way_to_a_real_one(stage, delegate):
    _spheres(stage, [((0.0, 0.0, 0.0), 2.0)])
    reader, problems = load(stage, delegate)
    path = usd_reader.DEFAULT_CAMERA_PATH
    assert reader.camera_path == path
    assert [(p.prim, p.attribute) for p in problems] == [(usd_reader.SETTINGS_FALLBACK_PATH,
                                                          "camera")]
    assert delegate.prims[path] == "camera"
    v = lambda k: delegate.value(path, k)  # noqa: E731
    m = matrix(v("transform"))
    eye, _, _ = _expected_eye([((0.0, 0.0, 0.0), 2.0)], False)
    # USD's row-vector matrices: the translation in the last row, no rotation down -Z
    assert np.allclose(m[3, :3], eye) and np.allclose(m[:3, :3], np.eye(3))
    near, far = floats(v("clippingRange"))[0]
    # the whole of the bounds between the clipping planes
    assert 0 < near < eye[2] - 2.0 and far > eye[2] + 2.0
    assert v("fStop") == 0.0 and v("focalLength") == 50.0
    assert delegate.value(reader.settings_path, "camera") == ("path", path)
    # an edit that moves the geometry keeps the view (as a viewer's free camera)
    UsdGeom.Xformable(stage.GetPrimAtPath("/World/S0")).GetOrderedXformOps()[0].Set(
        Gf.Vec3d(5, 0, 0))
    reader.update()
    assert np.allclose(matrix(v("transform"))[3, :3], eye)
    # a camera added to the stage is used, and the default one is gone
    camera(stage, "/NewCam", pos=(0, 0, 10))
    reader.update()
    assert reader.camera_path == "/NewCam"
    assert path not in delegate.prims
    assert delegate.value(reader.settings_path, "camera") == ("path", "/NewCam")


def test_an_empty_stage_frames_a_cube_about_the_origin(stage, delegate):
    reader, problems = load(stage, delegate)
    assert len(problems) == 1 and "empty" in problems[0].message
    m = matrix(delegate.value(reader.camera_path, "transform"))
    assert np.allclose(m[3, :3], _expected_eye([((0.0, 0.0, 0.0), 1.0)], False)[0])
