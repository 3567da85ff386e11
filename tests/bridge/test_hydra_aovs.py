"""Render buffers laid out as Hydra's want them (what hdx's picking, selection highlight and
depth compositing read, through the Hydra plugin's render pass): rows from the bottom, `depth`
as the clip-space depth of the camera's projection mapped to [0, 1], `cameraDepth` the distance
along the view axis, `primId`, `instanceId` and `elementId` (the authored face) as int32, each
holding its binding's clear value until a pass publishes. The expectations come from the scene's
geometry and usd-core's own projection matrix (`Gf.Camera`), as hdx unprojects a pick."""
import array
import math
import struct

from pxr import Gf

from tide import _tide

W, H = 32, 24
FOCAL, HAP, VAP = 20.0, 20.0, 15.0
NEAR, FAR = 0.5, 50.0
WALL_Z, QUAD_Z = -10.0, -4.0
# the wall stops below this height: the rows under it see nothing
WALL_BOTTOM = -1.0
# the wall's faces split it at these x: a quad, a pentagon (its fifth corner out of view above),
# a quad; the pentagon's three triangles are all face 1
WALL_SPLITS = (-0.6, 0.8)
# the instanced quad's rectangle (x0, x1, y0, y1) at QUAD_Z, and its instances' x offsets; the
# middle instance's matrix is not finite, so it is dropped and the third keeps its index 2
QUAD = (-1.9, -0.1, 0.1, 1.4)
OFFSETS = [0.0, None, 2.0]
WALL_ID, QUAD_ID = 5, 9


def floats(data):
    return array.array("f", data)


def translate(x):
    return [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x, 0, 0, 1]


def build(d):
    assert d.create_sprim("camera", "/Cam")
    d.set("/Cam", "focalLength", FOCAL)
    d.set("/Cam", "horizontalAperture", HAP)
    d.set("/Cam", "verticalAperture", VAP)
    d.set_array("/Cam", "clippingRange", floats([NEAR, FAR]), 2, "f")
    assert d.create_sprim("renderSettings", "/Render")
    d.set("/Render", "tide:samples", 1)
    d.set("/Render", "tide:integrator", ("token", "path"))
    assert d.create_sprim("domeLight", "/Dome")
    a, b = WALL_SPLITS
    y0, y1, z = WALL_BOTTOM, 20.0, WALL_Z
    wall = [(-20, y0), (a, y0), (b, y0), (20, y0), (20, y1), (b, y1), (a, y1), (-20, y1), ((a + b) / 2, y1 + 1)]
    x0, x1, qy0, qy1 = QUAD
    meshes = {
        "/Wall": (wall, [4, 5, 4], [0, 1, 6, 7, 1, 2, 5, 8, 6, 2, 3, 4, 5], WALL_Z, WALL_ID),
        "/Quad": ([(x0, qy0), (x1, qy0), (x1, qy1), (x0, qy1)], [4], [0, 1, 2, 3], QUAD_Z, QUAD_ID),
    }
    for path, (points, counts, indices, z, pid) in meshes.items():
        assert d.create_rprim("mesh", path)
        d.set_array(path, "points", floats([c for x, y in points for c in (x, y, z)]), 3, "f")
        d.set_array(path, "faceVertexCounts", counts, 1, "i")
        d.set_array(path, "faceVertexIndices", array.array("i", indices), 1, "i")
        d.set(path, "primId", pid)
    nan = float("nan")
    mats = [v for x in OFFSETS for v in (translate(x) if x is not None else [nan] * 16)]
    d.set_array("/Quad", "instanceTransforms", array.array("d", mats), 16, "d")


def buffer(d, path, fmt):
    assert d.create_bprim("renderBuffer", path)
    d.set_array(path, "dimensions", [W, H], 1, "i")
    d.set(path, "format", ("token", fmt))


def values(d, path):
    w, h, c, data = d.map_buffer(path)
    assert (w, h) == (W, H)
    v = struct.unpack("%df" % (len(data) // 4), data)
    return [v[i * w * c:(i + 1) * w * c] for i in range(h)]


def lens(x, y):
    """The direction (per unit of -z) the camera sees at image point (x, y) (pixels, rows from
    the top), from its aperture and focal length."""
    return (x / W * 2 - 1) * HAP / 2 / FOCAL, (1 - y / H * 2) * VAP / 2 / FOCAL


def through(proj):
    """The direction seen at an image point through a projection matrix (the camera at the
    origin looking down -z), as hdx unprojects a pick."""
    inv = proj.GetInverse()

    def ray(x, y):
        p = inv.Transform(Gf.Vec3d(x / W * 2 - 1, 1 - y / H * 2, -1))
        return p[0] / -p[2], p[1] / -p[2]
    return ray


def what_is_seen(col, row, ray=lens):
    """What the whole of the pixel (col, row from the top) sees: ('quad', instance, 0),
    ('wall', -1, face), ('miss', -1, -1), or None where its corners see different things."""
    seen = set()
    for u in (0.0, 1.0):
        for v in (0.0, 1.0):
            sx, sy = ray(col + u, row + v)
            x, y = -QUAD_Z * sx, -QUAD_Z * sy
            hit = None
            for k, off in enumerate(OFFSETS):
                if off is not None and QUAD[0] + off <= x <= QUAD[1] + off and QUAD[2] <= y <= QUAD[3]:
                    hit = ("quad", k, 0)
            if hit is None and -WALL_Z * sy >= WALL_BOTTOM:
                hit = ("wall", -1, sum(-WALL_Z * sx > split for split in WALL_SPLITS))
            hit = hit or ("miss", -1, -1)
            seen.add(hit)
    return seen.pop() if len(seen) == 1 else None


def test_hydra_buffers_hold_clip_depth_int_ids_and_rows_from_the_bottom():
    d = _tide.RenderDelegate()
    build(d)
    plain = {"color": "float4", "depth": "float", "primId": "float", "instanceId": "float", "elementId": "float"}
    hydra = {"color": "float4", "depth": "float", "cameraDepth": "float", "primId": "int32", "instanceId": "int32", "elementId": "int32"}
    for aov, fmt in plain.items():
        buffer(d, "/Out/usd/" + aov, fmt)
    for aov, fmt in hydra.items():
        buffer(d, "/Out/hd/" + aov, fmt)
    problems = d.commit_resources()
    assert [(p[0], p[1]) for p in problems] == [("/Quad", "instanceTransforms")], problems

    p = d.create_render_pass()
    p.execute("/Cam", [(a, "/Out/usd/" + a) for a in plain], "/Render")
    assert p.wait(60.0) and p.error() is None
    usd = {a: values(d, "/Out/usd/" + a) for a in plain}
    p.execute("/Cam", [(a, "/Out/hd/" + a) for a in hydra], "/Render", hydra=True)
    assert p.wait(60.0) and p.error() is None
    hd = {a: values(d, "/Out/hd/" + a) for a in hydra}
    assert d.commit_resources() == []

    # the same render, its rows from the bottom; cameraDepth is the film's depth
    assert hd["color"] == usd["color"][::-1]
    assert hd["cameraDepth"] == usd["depth"][::-1]
    assert hd["color"] != usd["color"], "the image must not read the same both ways up"

    check_picks(hd, usd, camera_projection(), lens)


def camera_projection(window=None):
    cam = Gf.Camera()
    cam.focalLength, cam.horizontalAperture, cam.verticalAperture = FOCAL, HAP, VAP
    cam.clippingRange = Gf.Range1f(NEAR, FAR)
    frustum = cam.frustum
    if window is not None:
        frustum.window = window
    return frustum.ComputeProjectionMatrix()


def check_picks(hd, usd, proj, ray):
    """Each pixel that sees one thing whole, picked as hdx does, finds it at its depth."""
    ndc_to_world = proj.GetInverse()  # the camera sits at the origin looking down -z
    counts = {}
    for row in range(H):
        for col in range(W):
            seen = what_is_seen(col, row, ray)
            if seen is None:
                continue
            kind, instance, element = seen
            counts[seen] = counts.get(seen, 0) + 1
            up = H - 1 - row
            depth = hd["depth"][up][col]
            want_id = {"quad": QUAD_ID, "wall": WALL_ID, "miss": -1}[kind]
            assert hd["primId"][up][col] == want_id, (col, row, seen)
            assert hd["instanceId"][up][col] == instance, (col, row, seen)
            if "elementId" in hd:
                assert hd["elementId"][up][col] == element, (col, row, seen)
            if usd is not None:
                assert usd["primId"][row][col] == want_id and usd["instanceId"][row][col] == instance
                assert usd["elementId"][row][col] == element
                assert math.isinf(usd["depth"][row][col]) == (kind == "miss")
            if kind == "miss":
                assert depth == 1.0
                continue
            z = QUAD_Z if kind == "quad" else WALL_Z
            want = (proj.Transform(Gf.Vec3d(0, 0, z))[2] + 1) / 2
            assert abs(depth - want) < 1e-6, (col, row, depth, want)
            # as hdx unprojects a pick: the pixel's centre at that depth lies on the surface
            ndc = Gf.Vec3d((col + 0.5) / W * 2 - 1, (up + 0.5) / H * 2 - 1, depth * 2 - 1)
            hit = ndc_to_world.Transform(ndc)
            assert abs(hit[2] - z) < 2e-4 * -z, (col, row, hit)
            sx, sy = ray(col + 0.5, row + 0.5)
            assert abs(hit[0] - -z * sx) < 1e-3 and abs(hit[1] - -z * sy) < 1e-3, (col, row, hit)
    # every case was seen by whole pixels
    wanted = [("quad", 0, 0), ("quad", 2, 0), ("miss", -1, -1)] + [("wall", -1, f) for f in range(3)]
    assert all(counts.get(k, 0) >= 4 for k in wanted), counts


def test_unknown_aovs_still_fail_a_usd_pass():
    d = _tide.RenderDelegate()
    build(d)
    buffer(d, "/Out/x", "float")
    d.commit_resources()
    p = d.create_render_pass()
    try:
        p.execute("/Cam", [("pointId", "/Out/x")], "/Render")
    except RuntimeError as e:
        assert "pointId" in str(e)
    else:
        raise AssertionError("a usd pass took an AOV Tide does not render")


def test_a_hydra_pass_frames_the_image_as_its_projection_says():
    """A Hydra pass's projection matrix (its framing and window policy: an off-centre crop of
    the frustum here, as usdview's camera mask makes) frames the image in place of the camera's
    own aperture: every pixel picks what that projection sees there. A matrix of another kind
    than the camera's is named, and the camera's aperture used."""
    d = _tide.RenderDelegate()
    build(d)
    hydra = {"color": "float4", "depth": "float", "primId": "int32", "instanceId": "int32"}
    for aov, fmt in hydra.items():
        buffer(d, "/Out/hd/" + aov, fmt)
    d.commit_resources()
    p = d.create_render_pass()
    bindings = [(a, "/Out/hd/" + a) for a in hydra]
    # a window of the image's aspect, off the axis: a crop of the left, upper part
    proj = camera_projection(Gf.Range2d(Gf.Vec2d(-0.45, -0.2), Gf.Vec2d(0.15, 0.25)))
    flat = [proj[i][j] for i in range(4) for j in range(4)]
    p.execute("/Cam", bindings, "/Render", hydra=True, projection=flat)
    assert p.wait(60.0) and p.error() is None
    assert d.commit_resources() == []
    framed = {a: values(d, "/Out/hd/" + a) for a in hydra}
    check_picks(framed, None, proj, through(proj))
    # the crop magnifies: the quad's instance 0 fills more pixels than the camera shows it in
    quad = lambda v: sum(x == 0 for row in v["instanceId"] for x in row)
    p.execute("/Cam", bindings, "/Render", hydra=True)
    assert p.wait(60.0) and p.error() is None
    whole = {a: values(d, "/Out/hd/" + a) for a in hydra}
    assert quad(framed) > 1.5 * quad(whole), (quad(framed), quad(whole))
    # an orthographic matrix for a perspective camera
    ortho = Gf.Frustum()
    ortho.projectionType = Gf.Frustum.Orthographic
    m = ortho.ComputeProjectionMatrix()
    p.execute("/Cam", bindings, "/Render", hydra=True, projection=[m[i][j] for i in range(4) for j in range(4)])
    assert p.wait(60.0) and p.error() is None
    problems = d.commit_resources()
    assert any(q[0] == "/Cam" and q[1] == "projection" for q in problems), problems
    assert values(d, "/Out/hd/color") == whole["color"]
    # said once, not at every execution (a viewer executes its pass each frame it draws)
    ortho_flat = [m[i][j] for i in range(4) for j in range(4)]
    p.execute("/Cam", bindings, "/Render", hydra=True, projection=ortho_flat)
    assert p.wait(60.0) and p.error() is None
    assert d.commit_resources() == []


def test_hydra_buffers_hold_their_clear_values_until_a_pass_publishes():
    """Each buffer holds its binding's clear value (hdx's: depth 1, ids -1) from when it is
    sized until a pass publishes into it: what hdx reads before the first pass ends, and after
    a resize."""
    d = _tide.RenderDelegate()
    build(d)
    hydra = {"color": "float4", "depth": "float", "primId": "int32", "elementId": "int32"}
    clear = {"color": [0.25, 0.5, 0.75, 0.0], "depth": 1.0, "primId": -1, "elementId": -1}
    for aov, fmt in hydra.items():
        buffer(d, "/Out/hd/" + aov, fmt)
    d.commit_resources()
    p = d.create_render_pass()
    bindings = [(a, "/Out/hd/" + a) for a in hydra]
    p.execute("/Cam", bindings, "/Render", hydra=True, clear_values={"/Out/hd/" + a: v for a, v in clear.items()})
    assert p.wait(60.0) and p.error() is None
    rendered = {a: values(d, "/Out/hd/" + a) for a in hydra}
    assert {v for row in rendered["primId"] for v in row} == {-1, WALL_ID, QUAD_ID}
    assert {v for row in rendered["elementId"] for v in row} == {-1, 0, 1, 2}
    # resized: the clear value at the new size
    for a in hydra:
        d.set_array("/Out/hd/" + a, "dimensions", [5, 3], 1, "i")
    assert d.commit_resources() == []
    for a, v in clear.items():
        w, h, c, data = d.map_buffer("/Out/hd/" + a)
        want = v if isinstance(v, list) else [v]
        assert (w, h, c) == (5, 3, len(want)), a
        assert list(struct.unpack("%df" % (len(data) // 4), data)) == want * 15, a
    # without clear values the next pass's buffers start from zeros
    with_zeros = {"/Out/hd/" + a: 0.0 for a in hydra if a != "color"}
    for a in hydra:
        d.set_array("/Out/hd/" + a, "dimensions", [4, 2], 1, "i")
    p.execute("/Cam", bindings, "/Render", hydra=True, clear_values=with_zeros)
    try:
        p.execute("/Cam", bindings, "/Render", hydra=True, clear_values={"/Out/elsewhere": 1.0})
    except ValueError as e:
        assert "/Out/elsewhere" in str(e)
    else:
        raise AssertionError("a clear value for a buffer not bound was taken")
    assert p.wait(60.0) and p.error() is None
