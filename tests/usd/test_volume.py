"""UsdVolVolume with OpenVDB fields (contract sections 2, 3, 7): the reader turns a Volume and
its OpenVDBAsset density field into a delegate `volume` prim and has each grid read once; a
rendered absorbing volume in front of a white dome transmits exp(-sigma_a * densityScale * the
integral of the density along the view), computed here from the grid we wrote; a missing file,
a missing field or a grid of the wrong type is reported naming the prim and attribute, and the
rest renders.

The VDB files are written by the bridge module's `write_vdb` (OpenVDB's Python bindings are not
on PyPI), so the rendering tests need the module; the reader tests use the recording fake.
"""
import math
import os

import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux, UsdShade, UsdVol

from conftest import exact_lambert_material, bind, camera, load, render, settings

# The grid: 16 x 16 x 4 voxels of 0.25, centred on the origin in x and y, the first value at
# z = -0.375. Values sit at voxel indices; between them the density is trilinear and outside
# the grid 0, so along z through the interior it ramps up over one voxel, is flat over three
# and ramps down over one: the integral of the density is value * 4 voxels * 0.25 = value * 1.
DIMS = (16, 16, 4)
VOXEL = 0.25
ORIGIN = (-1.875, -1.875, -0.375)
PATH_INTEGRAL = 4 * VOXEL


def write_grid(module, path, value=1.0, extra=()):
    values = np.full(DIMS[0] * DIMS[1] * DIMS[2], value, dtype=np.float32)
    grids = [("density", "float", DIMS, values.tobytes(), VOXEL, ORIGIN, (0, 0, 0))]
    grids += list(extra)
    module.write_vdb(str(path), grids)
    return str(path)


def medium_material(stage, path="/Looks/Fog", sigma_a=0.7, density_scale=1.0):
    mat = UsdShade.Material.Define(stage, path)
    med = UsdShade.Shader.Define(stage, path + "/Medium")
    med.CreateIdAttr("TideMedium")
    med.CreateInput("absorption", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(sigma_a, sigma_a, sigma_a))
    med.CreateInput("scattering", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    med.CreateInput("densityScale", Sdf.ValueTypeNames.Float).Set(density_scale)
    mat.CreateVolumeOutput().ConnectToSource(med.ConnectableAPI(), "volume")
    return mat


def volume(stage, file_path, path="/Cloud", field_name="density", mat=None, z=0.0):
    vol = UsdVol.Volume.Define(stage, path)
    if z:
        vol.AddTranslateOp().Set(Gf.Vec3d(0, 0, z))
    field = UsdVol.OpenVDBAsset.Define(stage, path + "/density")
    field.CreateFilePathAttr(file_path)
    field.CreateFieldNameAttr(field_name)
    vol.CreateFieldRelationship("density", field.GetPath())
    if mat is not None:
        bind(vol.GetPrim(), mat)
    return vol


def scene(stage, file_path, field_name="density", sigma_a=0.7, density_scale=1.0):
    """A white dome seen through the volume by a camera at z = 5 looking down -Z with a field
    of 2 * atan(0.02): path lengths through the volume differ by less than 2e-4."""
    camera(stage, pos=(0, 0, 5), focal=50.0, aperture=(2.0, 2.0))
    settings(stage, res=(16, 16), samples=64)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    mat = medium_material(stage, sigma_a=sigma_a, density_scale=density_scale)
    # the prim's own transform moves the grid by -1 in z: still in front of the camera
    volume(stage, file_path, field_name=field_name, mat=mat, z=-1.0)


def mean_and_error(img):
    """Per-channel mean over the image and its standard error (pixels are independent)."""
    rgb = img[..., :3].reshape(-1, 3).astype(np.float64)
    return rgb.mean(axis=0), rgb.std(axis=0, ddof=1) / math.sqrt(len(rgb))


def assert_transmits(img, expected):
    mean, se = mean_and_error(img)
    # 4 standard errors of the Monte Carlo mean, plus 2e-3 for the grey absorption's uplifted
    # spectrum (flat to 1e-3) and f32 accumulation
    assert np.all(np.abs(mean - expected) < 4 * se + 2e-3), (mean, se, expected)


# -- the reader (fake delegate) ---------------------------------------------------------------
def test_reader_sends_the_volume_and_reads_each_grid_once(stage, delegate, tmp_path):
    f = tmp_path / "cloud.vdb"
    f.write_bytes(b"not read by the fake")
    mat = medium_material(stage)
    volume(stage, str(f), "/A", mat=mat)
    volume(stage, str(f), "/B", mat=mat)
    field = UsdVol.OpenVDBAsset(stage.GetPrimAtPath("/B/density"))
    field.CreateFieldIndexAttr(0)
    reader, problems = load(stage, delegate)
    assert delegate.prims["/A"] == "volume"
    assert delegate.value("/A", "field:density") == ("asset", str(f))
    assert delegate.value("/A", "field:density:fieldName") == ("token", "density")
    assert delegate.value("/B", "field:density:fieldIndex") == 0
    assert delegate.value("/A", "material") == ("path", "/Looks/Fog")
    loads = [c for c in delegate.calls if c[0] == "load_vdb"]
    assert loads == [("load_vdb", str(f), "density", 0)], loads


# -- rendering (the real module) --------------------------------------------------------------
def test_volume_transmits_beer_lambert(renderer, stage, tmp_path):
    f = write_grid(renderer, tmp_path / "cloud.vdb")
    scene(stage, f, sigma_a=0.7)
    img = render(renderer, stage)["color"]
    assert_transmits(img, math.exp(-0.7 * PATH_INTEGRAL))


def test_a_sparse_grid_over_a_huge_box_renders(renderer, stage, tmp_path):
    """The cloud's grid with a second block 1200 voxels away along every axis: an active box
    of 1.8e9 voxels (7 GB as dense floats, refused before), held as its occupied 8^3 bricks.
    The far block is out of view: the camera sees the cloud's transmittance."""
    values = np.full(DIMS[0] * DIMS[1] * DIMS[2], 1.0, dtype=np.float32)
    far = np.full(4 * 4 * 4, 2.0, dtype=np.float32)
    f = str(tmp_path / "sparse.vdb")
    renderer.write_vdb(f, [("density", "float", DIMS, values.tobytes(), VOXEL, ORIGIN, (0, 0, 0)),
                           ("density", "float", (4, 4, 4), far.tobytes(), VOXEL, ORIGIN, (1200, 1200, 1200))])
    scene(stage, f, sigma_a=0.7)
    img = render(renderer, stage)["color"]
    assert_transmits(img, math.exp(-0.7 * PATH_INTEGRAL))


def test_density_scale_multiplies_the_grid(renderer, stage, tmp_path):
    f = write_grid(renderer, tmp_path / "cloud.vdb", value=0.5)
    scene(stage, f, sigma_a=0.7, density_scale=3.0)
    img = render(renderer, stage)["color"]
    expected = math.exp(-0.7 * 3.0 * 0.5 * PATH_INTEGRAL)
    assert_transmits(img, expected)
    # and differs clearly from the unscaled grid's exp(-0.35)
    assert abs(expected - math.exp(-0.7 * 0.5 * PATH_INTEGRAL)) > 0.2


def _problems_and_image(renderer, stage, file_path, field_name="density"):
    scene(stage, file_path, field_name=field_name)
    d = renderer.RenderDelegate()
    from tide import usd_reader
    r = usd_reader.Reader(stage, d)
    problems = r.load()
    return problems, _image(r, d)


def _image(reader, d):
    """The colour of a render pass of `reader`'s stage through delegate `d`, converged."""
    rp = reader.render_pass()
    for _ in range(600):
        if rp.is_converged():
            break
        rp.wait(0.1)
    w, h, c, data = d.map_buffer(reader.bindings()[0][1])
    return np.frombuffer(data, dtype=np.float32).reshape(h, w, c).copy()


def test_the_reader_reads_a_vdb_again_only_when_its_file_changes(stage, delegate, tmp_path):
    import os
    path = str(tmp_path / "fog.vdb")
    with open(path, "wb") as f:
        f.write(b"one")
    scene(stage, path)
    reader, _ = load(stage, delegate)
    reads = lambda: [c for c in delegate.calls if c[0] == "load_vdb"]  # noqa: E731
    assert reads() == [("load_vdb", path, "density", 0)]
    reader.update()
    assert len(reads()) == 1, "unchanged: not read again"
    st = os.stat(path)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    reader.update()
    assert reads()[1:] == [("load_vdb", path, "density", 0, "reload")]


def test_a_vdb_rewritten_on_disk_is_read_again(renderer, stage, tmp_path):
    """The grid's file rewritten with a quarter of the density: after update() the volume
    transmits exp(-0.7 x 0.25) and the image is a fresh load's, bit for bit (it kept the grid
    first read)."""
    import os
    from tide import usd_reader
    path = write_grid(renderer, tmp_path / "fog.vdb", 1.0)
    scene(stage, path)
    d = renderer.RenderDelegate()
    r = usd_reader.Reader(stage, d)
    assert r.load() == []
    assert_transmits(_image(r, d), math.exp(-0.7 * PATH_INTEGRAL))
    st = os.stat(path)
    write_grid(renderer, path, 0.25)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    r.update()
    again = _image(r, d)
    assert_transmits(again, math.exp(-0.7 * 0.25 * PATH_INTEGRAL))
    fresh_d = renderer.RenderDelegate()
    fresh = usd_reader.Reader(stage, fresh_d)
    fresh.load()
    assert np.array_equal(again, _image(fresh, fresh_d))


def test_missing_vdb_file_is_reported_and_the_rest_renders(renderer, stage, tmp_path):
    problems, img = _problems_and_image(renderer, stage, str(tmp_path / "nowhere.vdb"))
    keys = {(p.prim, p.attribute) for p in problems}
    assert ("/Cloud/density", "filePath") in keys, problems
    # the volume is dropped: the dome is seen unattenuated
    assert_transmits(img, 1.0)


def test_a_grid_whose_voxels_lie_billions_apart_is_reported_not_read(renderer, stage):
    """data/wrapping_box.vdb (19 KB): a float grid `density` of two active voxels written by
    `write_vdb`, one leaf's origin then moved to (2111062016, 1824456704, 121556992) in the
    file. Its active box would hold ~5e26 voxels, whose count wrapped around in 64 bits, passed
    the size check and had the copy write past its buffer (a segfault). It is named and
    dropped; the rest renders."""
    f = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "wrapping_box.vdb")
    problems, img = _problems_and_image(renderer, stage, f)
    hits = [p for p in problems if "voxels" in p.message]
    assert hits and hits[0].prim.startswith("/Cloud"), problems
    assert_transmits(img, 1.0)


def test_missing_field_is_reported_on_the_volume(renderer, stage, tmp_path):
    f = write_grid(renderer, tmp_path / "cloud.vdb")
    problems, img = _problems_and_image(renderer, stage, f, field_name="smoke")
    hits = [p for p in problems if (p.prim, p.attribute) == ("/Cloud", "field:density")]
    assert hits and "smoke" in hits[0].message, problems
    assert_transmits(img, 1.0)


def test_wrong_grid_type_is_reported_on_the_volume(renderer, stage, tmp_path):
    vel = ("vel", "vec3", (2, 2, 2), np.ones(8, dtype=np.float32).tobytes(), VOXEL, ORIGIN,
           (0, 0, 0))
    f = write_grid(renderer, tmp_path / "cloud.vdb", extra=[vel])
    problems, img = _problems_and_image(renderer, stage, f, field_name="vel")
    hits = [p for p in problems if (p.prim, p.attribute) == ("/Cloud", "field:density")]
    assert hits and "not a float" in hits[0].message, problems
    assert_transmits(img, 1.0)


def test_the_field_prims_own_transform_places_the_grid(stage, delegate, tmp_path):
    """A field prim with its own translation: the reader sends its placement relative to the
    volume (the volume's own transform is not in it)."""
    from conftest import matrix
    f = tmp_path / "cloud.vdb"
    f.write_bytes(b"not read by the fake")
    vol = volume(stage, str(f), "/A", mat=medium_material(stage), z=-1.0)
    UsdGeom.Xformable(stage.GetPrimAtPath("/A/density")).AddTranslateOp().Set(Gf.Vec3d(3, 0, 0))
    load(stage, delegate)
    m = matrix(delegate.value("/A", "field:density:transform"))
    assert np.allclose(m[3, :3], [3, 0, 0]) and np.allclose(m[:3, :3], np.eye(3)), m
    assert vol  # the volume itself keeps its own transform
    assert np.allclose(matrix(delegate.value("/A", "transform"))[3, :3], [0, 0, -1])


def test_a_field_moved_out_of_view_leaves_the_dome_unobstructed(renderer, stage, tmp_path):
    f = write_grid(renderer, tmp_path / "cloud.vdb")
    scene(stage, f, sigma_a=0.7)
    # the grid is 4 m wide; 10 m to the side it is far outside the camera's 0.8 m-wide view
    UsdGeom.Xformable(stage.GetPrimAtPath("/Cloud/density")).AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    img = render(renderer, stage)["color"]
    assert_transmits(img, 1.0)
    # and back in place it absorbs as before (the same stage without the move)
    stage.GetPrimAtPath("/Cloud/density").GetAttribute("xformOp:translate").Set(Gf.Vec3d(0, 0, 0))
    img = render(renderer, stage)["color"]
    assert_transmits(img, math.exp(-0.7 * PATH_INTEGRAL))


def test_a_volume_moving_over_the_shutter_blurs(renderer, stage, tmp_path):
    """The volume's translation sweeps it from x = -6 to x = +6 over the shutter (frames 0 to
    1) across the camera's 0.08 m-wide view: the time-averaged transmittance of its profile
    across x (16 grid points 0.25 apart: flat over 3.75 m, a one-voxel ramp on either side),
    [(12 - 4.25) + 3.75 e^-k + 2 * 0.25 (1 - e^-k) / k] / 12 with k = sigma_a * the integral of
    the density along the view. Still at either end it would not be seen at all."""
    f = write_grid(renderer, tmp_path / "cloud.vdb")
    camera(stage, pos=(0, 0, 5), focal=50.0, aperture=(2.0, 2.0),
           **{"shutter__open": 0.0, "shutter__close": 1.0})
    settings(stage, res=(16, 16), samples=64)
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateIntensityAttr(1.0)
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    vol = volume(stage, f, mat=medium_material(stage, sigma_a=0.7))
    op = vol.AddTranslateOp()
    op.Set(Gf.Vec3d(-6, 0, -1), 0)
    op.Set(Gf.Vec3d(6, 0, -1), 1)
    img = render(renderer, stage)["color"]
    k = 0.7 * PATH_INTEGRAL
    expected = ((12 - 4.25) + 3.75 * math.exp(-k) + 0.5 * (1 - math.exp(-k)) / k) / 12
    assert_transmits(img, expected)
    assert expected < 0.92


@pytest.mark.parametrize("through", ["volume", "dense fog", "cut-out panel"])
def test_the_depth_of_a_wall_seen_through_a_volume_is_its_distance_from_the_camera(
        renderer, stage, tmp_path, through):
    """A grey wall (albedo 0.5) at z = -3 seen by a camera at z = 5 (8 units) through the
    volume's box, a dense scattering fog (most camera paths scatter before the wall) or a
    panel cut out by an opacity of 0 (at z = 2): the depth AOV reads 8 everywhere, the normal
    the wall's (0, 0, 1) and the albedo the wall's. The depth was measured from where the ray
    left the box or passed the panel (about 4.3 and 3), and infinite where the path scattered
    first; the normal was zero where every sample of a pixel scattered first and the albedo
    diluted by the samples that did (0.44 on average through the volume)."""
    camera(stage, pos=(0, 0, 5), focal=50.0, aperture=(2.0, 2.0))
    settings(stage, res=(8, 8), samples=4, vars_=("color", "depth", "normal", "albedo"))
    UsdLux.DomeLight.Define(stage, "/Dome")
    if through == "volume":
        volume(stage, write_grid(renderer, tmp_path / "fog.vdb", 0.2), mat=medium_material(stage), z=-1.0)
    elif through == "dense fog":
        fog = medium_material(stage, sigma_a=0.1)
        UsdShade.Shader(stage.GetPrimAtPath("/Looks/Fog/Medium")).GetInput("scattering").Set(Gf.Vec3f(3, 3, 3))
        volume(stage, write_grid(renderer, tmp_path / "fog.vdb", 1.0), mat=fog, z=-1.0)
    else:
        from conftest import preview_material
        cut = UsdGeom.Mesh.Define(stage, "/Cut")
        cut.CreatePointsAttr([(-3, -3, 2), (3, -3, 2), (3, 3, 2), (-3, 3, 2)])
        cut.CreateFaceVertexCountsAttr([4])
        cut.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        bind(cut.GetPrim(), preview_material(stage, "/Looks/Cut", opacity=0.0))
    wall = UsdGeom.Mesh.Define(stage, "/Wall")
    wall.CreatePointsAttr([(-9, -9, -3), (9, -9, -3), (9, 9, -3), (-9, 9, -3)])
    wall.CreateFaceVertexCountsAttr([4])
    wall.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(wall.GetPrim(), exact_lambert_material(stage, "/Looks/Grey", 0.5))
    out = render(renderer, stage)
    depth = out["depth"][..., 0]
    assert np.allclose(depth, 8.0, rtol=1e-4), depth
    assert np.allclose(out["normal"], (0.0, 0.0, 1.0), atol=1e-4), out["normal"]
    # the albedo of a grey surface, estimated from each sample's wavelengths (noisy per
    # sample, 0.5 on average)
    albedo = out["albedo"].astype(np.float64)
    assert abs(albedo.mean() - 0.5) < 0.03 and albedo.min() > 0.2, (albedo.mean(), albedo.min())
