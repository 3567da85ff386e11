"""UsdGeomBasisCurves: what the reader sends, and tubes and ribbons rendered at their widths
(expectations from the camera model, as in test_render.py)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, UsdGeom, UsdLux

from conftest import bind, camera, darkness, floats, lambert_material, load, render, settings

F, AP = 50.0, 36.0


def _curves(stage, path, points, counts, **attrs):
    c = UsdGeom.BasisCurves.Define(stage, path)
    c.CreatePointsAttr([Gf.Vec3f(*p) for p in points])
    c.CreateCurveVertexCountsAttr(counts)
    for k, v in attrs.items():
        c.GetPrim().GetAttribute(k).Set(v)
    return c


def test_reader_sends_curves_with_their_widths_and_normals(stage, delegate):
    camera(stage)
    c = _curves(stage, "/Hair", [(0, 0, 0), (1, 0, 0), (2, 1, 0), (3, 1, 0)], [4],
                type="cubic", basis="catmullRom", wrap="pinned")
    c.CreateWidthsAttr([0.1, 0.2, 0.3, 0.4])
    c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    c.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 4)
    r, problems = load(stage, delegate)
    assert problems == []
    assert delegate.prims["/Hair"] == "basisCurves"
    v = lambda k: delegate.value("/Hair", k)  # noqa: E731
    assert floats(v("curveVertexCounts")).tolist() == [4]
    assert (v("type"), v("basis"), v("wrap")) == (("token", "cubic"), ("token", "catmullRom"),
                                                  ("token", "pinned"))
    interp, data, tsize, _ = delegate.primvars["/Hair"]["widths"]
    assert interp == "vertex" and np.asarray(data, np.float32).tolist() == pytest.approx(
        [0.1, 0.2, 0.3, 0.4])
    assert delegate.primvars["/Hair"]["normals"][0] == "vertex"


def test_reader_reports_bad_curves(stage, delegate):
    camera(stage)
    _curves(stage, "/Short", [(0, 0, 0), (1, 0, 0)], [3])
    _curves(stage, "/Odd", [(0, 0, 0), (1, 0, 0)], [2], wrap="spiral")
    r, problems = load(stage, delegate)
    got = sorted((p.prim, p.attribute) for p in problems)
    assert got == [("/Odd", "wrap"), ("/Short", "curveVertexCounts")]
    assert "/Short" not in delegate.prims
    assert delegate.value("/Odd", "wrap") == ("token", "nonperiodic")


def _scene(stage, **curve_attrs):
    w = h = 64
    camera(stage, focal=F, aperture=(AP, AP))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateColorAttr(Gf.Vec3f(1, 1, 1))
    black = lambert_material(stage, "/Looks/Black", (0, 0, 0))
    settings(stage, res=(w, h), samples=16)
    return w, black


def _px_per_unit(z, w):
    return F / -z / (AP / 2) * w / 2


@pytest.mark.parametrize("oriented", [False, True])
def test_a_curve_covers_its_width_times_its_length(renderer, stage, oriented):
    # a straight 4-unit curve 10 units away, 0.4 wide: a tube (seen side-on, its octagon shows
    # its full diameter) or a ribbon facing the camera covers 4 x 0.4 units of the image
    w, black = _scene(stage)
    c = _curves(stage, "/Rope", [(-2, 0.5, -10), (2, 0.5, -10)], [2], type="linear")
    c.CreateWidthsAttr([0.4])
    if oriented:
        c.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 2)
    bind(c.GetPrim(), black)
    d = darkness(render(renderer, stage)["color"])
    k = _px_per_unit(-10.0, w)
    assert d.sum() == pytest.approx(4.0 * 0.4 * k * k, rel=0.04)
    ys, xs = np.mgrid[0:w, 0:w]
    cy = (d * (ys + 0.5)).sum() / d.sum()
    assert abs(cy - (w / 2 - 0.5 * k)) < 0.25


def test_a_pinned_bspline_reaches_its_end_vertices(renderer, stage):
    # a pinned cubic B-spline starts and ends at its end vertices; a nonperiodic one starts at
    # (P0 + 4 P1 + P2) / 6: here x = -5/6, 7/6 in from the end vertex (and the same at the end)
    w, black = _scene(stage)
    pts = [(-2, -1, -10), (-1, -1, -10), (1, -1, -10), (2, -1, -10)]
    for wrap, inset in (("pinned", 0.0), ("nonperiodic", 7.0 / 6.0)):
        path = "/Curve_" + wrap
        c = _curves(stage, path, pts, [4], basis="bspline", wrap=wrap)
        c.CreateWidthsAttr([0.3])
        c.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)])
        bind(c.GetPrim(), black)
        d = darkness(render(renderer, stage)["color"])
        stage.RemovePrim(path)
        k = _px_per_unit(-10.0, w)
        cols = np.nonzero(d.sum(axis=0) > 0.15 * 0.3 * k)[0]
        left, right = cols.min(), cols.max() + 1
        assert left == pytest.approx(w / 2 - (2 - inset) * k, abs=1.0), wrap
        assert right == pytest.approx(w / 2 + (2 - inset) * k, abs=1.0), wrap


def _nurbs_arc(stage, path, **attrs):
    # a rational quadratic quarter circle of radius 2 about (0, 0, -10): exact on the circle
    c = UsdGeom.NurbsCurves.Define(stage, path)
    c.CreatePointsAttr([Gf.Vec3f(2, 0, -10), Gf.Vec3f(2, 2, -10), Gf.Vec3f(0, 2, -10)])
    c.CreateCurveVertexCountsAttr([3])
    c.CreateOrderAttr([3])
    c.CreateKnotsAttr([0, 0, 0, 1, 1, 1])
    c.CreatePointWeightsAttr([1.0, 0.5 ** 0.5, 1.0])
    for k, v in attrs.items():
        c.GetPrim().GetAttribute(k).Set(v)
    return c


def test_nurbs_curves_are_evaluated_exactly(stage, delegate):
    camera(stage)
    c = _nurbs_arc(stage, "/Arc")
    c.CreateWidthsAttr([0.1, 0.2, 0.3])
    c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    r, problems = load(stage, delegate)
    assert problems == []
    assert delegate.prims["/Arc"] == "basisCurves"
    pts = floats(delegate.value("/Arc", "points"))
    assert delegate.value("/Arc", "type") == ("token", "linear")
    assert floats(delegate.value("/Arc", "curveVertexCounts")).tolist() == [len(pts)]
    assert len(pts) == 17
    # every sample on the circle (a polynomial curve through these points would not be)
    radius = np.hypot(pts[:, 0], pts[:, 1])
    assert np.allclose(radius, 2.0, atol=1e-5) and np.allclose(pts[:, 2], -10)
    assert np.allclose(pts[0], [2, 0, -10]) and np.allclose(pts[-1], [0, 2, -10], atol=1e-6)
    # widths blend through the same rational basis: the ends keep their values, the middle
    # (u = 1/2: basis 1/4, 1/2, 1/4 weighted by 1, 1/sqrt2, 1) lies in between
    interp, data, _, _ = delegate.primvars["/Arc"]["widths"]
    w = np.asarray(data, np.float32)
    assert interp == "vertex" and len(w) == len(pts)
    assert w[0] == pytest.approx(0.1) and w[-1] == pytest.approx(0.3)
    b = np.array([0.25, 0.5 * 0.5 ** 0.5, 0.25])
    assert w[8] == pytest.approx(float(b @ [0.1, 0.2, 0.3] / b.sum()), rel=1e-5)


def test_bad_nurbs_curves_are_reported(stage, delegate):
    camera(stage)
    _nurbs_arc(stage, "/ShortKnots", knots=[0, 0, 1, 1, 1])
    _nurbs_arc(stage, "/Backwards", knots=[0, 0, 1, 0, 1, 1])
    _nurbs_arc(stage, "/Zero", pointWeights=[1.0, 0.0, 1.0])
    _nurbs_arc(stage, "/Good")
    _, problems = load(stage, delegate)
    got = sorted((p.prim, p.attribute) for p in problems)
    assert got == [("/Backwards", "knots"), ("/ShortKnots", "knots"), ("/Zero", "pointWeights")]
    assert "/Good" in delegate.prims and "/ShortKnots" not in delegate.prims


def test_a_nurbs_curve_broken_by_a_repeated_knot_is_drawn_in_pieces(stage, delegate):
    """Knots [0 0 0 1 1 1 2 2 2] on six control points of order 3: the interior knot repeated
    3 times breaks the curve into two quadratic Beziers (P0 P1 P2 and P3 P4 P5), drawn as two
    curves with nothing between P2 and P3 (they were joined by a segment); each piece keeps
    its widths. A range past the knots' domain is drawn within it and reported."""
    camera(stage)
    ctl = np.array([(0, 0, 0), (1, 2, 0), (2, 0, 0), (4, 0, 0), (5, 2, 0), (6, 0, 0)], float)
    c = UsdGeom.NurbsCurves.Define(stage, "/Broken")
    c.CreatePointsAttr([Gf.Vec3f(*p) for p in ctl])
    c.CreateCurveVertexCountsAttr([6])
    c.CreateOrderAttr([3])
    c.CreateKnotsAttr([0, 0, 0, 1, 1, 1, 2, 2, 2])
    c.CreateWidthsAttr([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    _nurbs_arc(stage, "/Wide", ranges=[Gf.Vec2d(-1, 2)])
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Wide", "ranges")], problems
    counts = floats(delegate.value("/Broken", "curveVertexCounts")).astype(int).tolist()
    pts = floats(delegate.value("/Broken", "points"))
    assert counts == [17, 17] and len(pts) == 34
    first, second = pts[:17], pts[17:]
    bezier = lambda p, t: (1 - t) ** 2 * p[0] + 2 * t * (1 - t) * p[1] + t * t * p[2]  # noqa: E731
    for piece, p in ((first, ctl[:3]), (second, ctl[3:])):
        assert np.allclose(piece[0], p[0]) and np.allclose(piece[-1], p[2])
        assert np.allclose(piece, [bezier(p, t) for t in np.linspace(0, 1, 17)], atol=1e-6)
    w = np.asarray(delegate.primvars["/Broken"]["widths"][1], np.float32)
    assert w[16] == pytest.approx(0.3) and w[17] == pytest.approx(0.4)
    # the wide range is the whole arc
    arc = floats(delegate.value("/Wide", "points"))
    assert np.allclose(arc[0], [2, 0, -10]) and np.allclose(arc[-1], [0, 2, -10], atol=1e-6)


def test_a_nurbs_patch_broken_by_a_repeated_knot_has_no_strip_across_the_break(stage, delegate):
    """A bilinear patch whose u knots [0 0 1 1 2 2] repeat 1 twice (order 2): two flat
    sheets, x in [0, 1] and [3, 4], with no quads over the gap between x = 1 and 3; normals
    stay +z up to the break."""
    camera(stage)
    _nurbs_patch(stage, "/Sheets", [(x, y, 0) for y in (0, 1) for x in (0, 1, 3, 4)],
                 (4, 2, [0, 0, 1, 1, 2, 2]), (2, 2, [0, 0, 1, 1]))
    _, problems = load(stage, delegate)
    assert problems == []
    pts = floats(delegate.value("/Sheets", "points"))
    idx = floats(delegate.value("/Sheets", "faceVertexIndices")).astype(int).reshape(-1, 4)
    corners = pts[idx]
    spans = corners[:, :, 0].max(axis=1) - corners[:, :, 0].min(axis=1)
    assert len(idx) > 0 and spans.max() <= 1.0 + 1e-9, spans
    assert set(np.round(pts[:, 0], 6)) == {0.0, 1.0, 3.0, 4.0}
    n = np.asarray(delegate.primvars["/Sheets"]["normals"][1], np.float32).reshape(-1, 3)
    assert np.allclose(n / np.linalg.norm(n, axis=1)[:, None], [0, 0, 1], atol=1e-6)


def test_a_nurbs_circle_renders_as_a_ring(renderer, stage):
    # a full circle of radius 2 (nine rational quadratic vertices) drawn as a tube 0.2 wide,
    # 10 units away: its ring covers 2 pi r w units of the image
    w, black = _scene(stage)
    s = 0.5 ** 0.5
    pts = [(2, 0), (2, 2), (0, 2), (-2, 2), (-2, 0), (-2, -2), (0, -2), (2, -2), (2, 0)]
    c = UsdGeom.NurbsCurves.Define(stage, "/Ring")
    c.CreatePointsAttr([Gf.Vec3f(x, y, -10) for x, y in pts])
    c.CreateCurveVertexCountsAttr([9])
    c.CreateOrderAttr([3])
    c.CreateKnotsAttr([0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4])
    c.CreatePointWeightsAttr([1, s, 1, s, 1, s, 1, s, 1])
    c.CreateWidthsAttr([0.2])
    bind(c.GetPrim(), black)
    d = darkness(render(renderer, stage)["color"])
    k = _px_per_unit(-10.0, w)
    assert d.sum() == pytest.approx(2 * np.pi * 2.0 * 0.2 * k * k, rel=0.05)
    # no ink at the centre, ink on the ring
    assert d[w // 2, w // 2] < 0.05 and d[w // 2, int(w / 2 + 2 * k)] > 0.5


def test_hermite_curves_become_the_same_bezier_curves(stage, delegate):
    camera(stage)
    c = UsdGeom.HermiteCurves.Define(stage, "/H")
    c.CreatePointsAttr([(0, 0, 0), (3, 0, 0), (3, 3, 0)])
    c.CreateTangentsAttr([(3, 3, 0), (3, 0, 0), (0, 6, 0)])
    c.CreateCurveVertexCountsAttr([3])
    c.CreateWidthsAttr([0.3, 0.6, 0.9])
    c.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.value("/H", "basis") == ("token", "bezier")
    pts = floats(delegate.value("/H", "points"))
    assert floats(delegate.value("/H", "curveVertexCounts")).tolist() == [7]
    # a Hermite segment (P0, T0, P1, T1) is the bezier (P0, P0 + T0/3, P1 - T1/3, P1)
    assert np.allclose(pts, [(0, 0, 0), (1, 1, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0), (3, 1, 0),
                             (3, 3, 0)])
    w = np.asarray(delegate.primvars["/H"]["widths"][1], np.float32)
    assert np.allclose(w, [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])


def test_hermite_tangents_with_time_samples_bend_the_curve_over_the_shutter(stage, delegate):
    """Still points, tangents sampled at frames 0 and 1 (the shutter): the bezier sent at each
    end of the shutter has the inner vertices P +- T/3 of that time's tangents (they were the
    frame's at both ends, so the curve did not bend)."""
    camera(stage, **{"shutter__open": 0.0, "shutter__close": 1.0})
    settings(stage)
    c = UsdGeom.HermiteCurves.Define(stage, "/H")
    c.CreatePointsAttr([(0, 0, 0), (3, 0, 0)])
    c.CreateCurveVertexCountsAttr([2])
    c.CreateTangentsAttr().Set([(3, 0, 0), (3, 0, 0)], 0)
    c.GetTangentsAttr().Set([(0, 3, 0), (0, -3, 0)], 1)
    _, problems = load(stage, delegate)
    assert problems == []
    sent = delegate.samples("/H", "points")
    assert sorted(sent) == [0.0, 1.0], sent
    assert np.allclose(floats(sent[0.0]), [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)])
    assert np.allclose(floats(sent[1.0]), [(0, 0, 0), (0, 1, 0), (3, 1, 0), (3, 0, 0)])


def _nurbs_patch(stage, path, points, u, v, weights=None):
    """A NurbsPatch of `points` (v-major, u fastest); u and v are (vertex count, order, knots)."""
    p = UsdGeom.NurbsPatch.Define(stage, path)
    p.CreatePointsAttr([Gf.Vec3f(*q) for q in points])
    p.CreateUVertexCountAttr(u[0])
    p.CreateVVertexCountAttr(v[0])
    p.CreateUOrderAttr(u[1])
    p.CreateVOrderAttr(v[1])
    p.CreateUKnotsAttr(u[2])
    p.CreateVKnotsAttr(v[2])
    if weights is not None:
        p.CreatePointWeightsAttr(weights)
    return p


def _quarter_cylinder(stage, path="/P"):
    s = 0.5 ** 0.5
    arc = [(2, 0), (2, 2), (0, 2)]
    return _nurbs_patch(stage, path, [(x, y, z) for z in (0, 4) for x, y in arc],
                        (3, 3, [0, 0, 0, 1, 1, 1]), (2, 2, [0, 0, 1, 1]), [1, s, 1, 1, s, 1])


def test_a_nurbs_patch_renders_its_exact_surface(stage, delegate):
    # a rational quadratic quarter cylinder of radius 2 (u: the arc, v: straight, 0..4):
    # every grid point lies on the cylinder, and the normals point away from its axis
    camera(stage)
    _quarter_cylinder(stage)
    _, problems = load(stage, delegate)
    assert problems == []
    assert delegate.prims["/P"] == "mesh"
    pts = floats(delegate.value("/P", "points"))
    assert len(pts) == 9 * 2
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 2.0, atol=1e-5)
    assert sorted(set(np.round(pts[:, 2], 6))) == [0.0, 4.0]
    interp, data, _, _ = delegate.primvars["/P"]["normals"]
    n = np.asarray(data, np.float32).reshape(-1, 3)
    radial = pts[:, :2] / 2.0
    # du x dv: the arc runs counter-clockwise about +z, v along +z: the normals point out
    assert np.allclose(n[:, :2], radial, atol=0.03) and np.allclose(n[:, 2], 0, atol=1e-5)
    assert floats(delegate.value("/P", "faceVertexCounts")).tolist() == [4] * 8


def test_a_nurbs_patch_carries_its_primvars(stage, delegate):
    """A patch's constant displayColor is sent as it is; a vertex primvar (one value per
    control point) is carried onto the surface's points as the points are: a per-point value
    equal to the control point's z reads each surface point's z."""
    camera(stage)
    p = _quarter_cylinder(stage)
    p.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([(1, 0, 0)])
    UsdGeom.PrimvarsAPI(p.GetPrim()).CreatePrimvar("height", Sdf.ValueTypeNames.FloatArray,
                                                   UsdGeom.Tokens.vertex).Set([0, 0, 0, 4, 4, 4])
    UsdGeom.PrimvarsAPI(p.GetPrim()).CreatePrimvar("bad", Sdf.ValueTypeNames.FloatArray,
                                                   UsdGeom.Tokens.uniform).Set([1.0])
    _, problems = load(stage, delegate)
    assert [(q.prim, q.attribute) for q in problems] == [("/P", "primvars:bad")]
    pv = delegate.primvars["/P"]
    assert pv["displayColor"][0] == "constant"
    assert np.allclose(np.asarray(pv["displayColor"][1], np.float32), [1, 0, 0])
    pts = floats(delegate.value("/P", "points"))
    interp, data, _, _ = pv["height"]
    assert interp == "vertex" and np.allclose(np.asarray(data, np.float32), pts[:, 2], atol=1e-5)
    assert "bad" not in pv


def _plane_patch(stage, n):
    """/Big: an n x n bicubic patch of the surface z = x y / 100 (control points on it)."""
    p = UsdGeom.NurbsPatch.Define(stage, "/Big")
    xs = np.arange(n, dtype=np.float64)
    p.CreatePointsAttr([Gf.Vec3f(float(x), float(y), float(x * y / 100.0)) for y in xs for x in xs])
    for d in "uv":
        getattr(p, "Create%sVertexCountAttr" % d.upper())(n)
        getattr(p, "Create%sOrderAttr" % d.upper())(4)
        getattr(p, "Create%sKnotsAttr" % d.upper())([0] * 4 + list(range(1, n - 3)) + [n - 3] * 4)
    return p


def test_a_nurbs_patch_of_many_control_points_is_evaluated_one_direction_at_a_time(stage, delegate):
    """An 80 x 80 bicubic patch (a plane z = x y / 100): the points sent lie on it. As one
    matrix over every control point its evaluation took tens of gigabytes."""
    camera(stage)
    _plane_patch(stage, 80)
    _, problems = load(stage, delegate)
    assert problems == []
    pts = floats(delegate.value("/Big", "points"))
    # a bilinear function is reproduced by a bicubic spline of its samples (linear precision
    # in each direction)
    assert np.allclose(pts[:, 2], pts[:, 0] * pts[:, 1] / 100.0, atol=1e-3)


def test_a_nurbs_patch_past_the_grid_bound_is_drawn_coarser_and_named(stage, delegate, monkeypatch):
    """With the bound on a patch's grid lowered to 10 000 points, an 80 x 80 bicubic patch
    (380 000 points at 8 samples per span) is drawn with fewer samples per span, within the
    bound and still on its surface, and named on its points (a 400 x 400 net took 4.4 GB and
    aborted; the bound is 2^22 points, as subdivision's on refined faces)."""
    from tide import nurbs
    monkeypatch.setattr(nurbs, "MAX_PATCH_POINTS", 10_000)
    camera(stage)
    _plane_patch(stage, 80)
    _, problems = load(stage, delegate)
    assert [(q.prim, q.attribute) for q in problems] == [("/Big", "points")], problems
    pts = floats(delegate.value("/Big", "points"))
    assert len(pts) <= 10_000
    assert np.allclose(pts[:, 2], pts[:, 0] * pts[:, 1] / 100.0, atol=1e-3)


def test_a_nurbs_curve_of_many_control_points_is_evaluated_span_by_span(stage, delegate):
    """A cubic curve of 12 000 control points tracing the parabola y = x^2 / 1000 (its control
    points are the blossoms of x and x^2 at each three consecutive knots, which a cubic
    B-spline reproduces exactly): the polyline sent lies on it. As one dense matrix over every
    control point its 190 000 samples took 18 GB and the curve was dropped."""
    camera(stage)
    n = 12000
    knots = np.array([0.0] * 4 + list(range(1, n - 3)) + [n - 3.0] * 4)
    t = np.stack([knots[1:n + 1], knots[2:n + 2], knots[3:n + 3]], axis=1)
    x = t.mean(axis=1)
    y = (t[:, 0] * t[:, 1] + t[:, 0] * t[:, 2] + t[:, 1] * t[:, 2]) / 3.0 / 1000.0
    c = UsdGeom.NurbsCurves.Define(stage, "/Long")
    c.CreatePointsAttr([Gf.Vec3f(float(a), float(b), 0.0) for a, b in zip(x, y)])
    c.CreateCurveVertexCountsAttr([n])
    c.CreateOrderAttr([4])
    c.CreateKnotsAttr(knots.tolist())
    _, problems = load(stage, delegate)
    assert problems == []
    pts = floats(delegate.value("/Long", "points")).astype(np.float64)
    assert len(pts) > 180_000
    want = pts[:, 0] ** 2 / 1000.0
    assert np.allclose(pts[:, 1], want, rtol=1e-5, atol=1e-3), np.abs(pts[:, 1] - want).max()


def test_a_nurbs_sphere_has_its_normals_at_the_poles(stage, delegate):
    """A rational sphere's pole rows collapse to a point where the derivatives' cross product
    vanishes: the normals there are the axis, not zero."""
    camera(stage)
    s = 0.5 ** 0.5
    p = UsdGeom.NurbsPatch.Define(stage, "/S")
    # v: a half circle from the south pole to the north (x >= 0 in the xz... plane), u: the
    # full turn about y (a rational quadratic circle of 9 points)
    ring = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    rw = [1, s, 1, s, 1, s, 1, s, 1]
    half = [(0, -1), (1, -1), (1, 0), (1, 1), (0, 1)]
    hw = [1, s, 1, s, 1]
    p.CreatePointsAttr([Gf.Vec3f(r * cx, y, r * cz) for r, y in half for cx, cz in ring])
    p.CreatePointWeightsAttr([a * b for a in hw for b in rw])
    p.CreateUVertexCountAttr(9)
    p.CreateVVertexCountAttr(5)
    p.CreateUOrderAttr(3)
    p.CreateVOrderAttr(3)
    p.CreateUKnotsAttr([0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 4])
    p.CreateVKnotsAttr([0, 0, 0, 1, 1, 2, 2, 2])
    _, problems = load(stage, delegate)
    assert problems == []
    pts = floats(delegate.value("/S", "points"))
    assert np.allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-5)
    n = np.asarray(delegate.primvars["/S"]["normals"][1], np.float32).reshape(-1, 3)
    assert np.all(np.linalg.norm(n, axis=1) > 0.99)
    pole = np.abs(pts[:, 1]) > 1 - 1e-6
    assert pole.any()
    # along the axis (either way round: the patch's orientation decides), within 1 degree
    assert np.all(np.abs(n[pole][:, 1]) > np.cos(np.radians(1.0))), n[pole]


def test_a_tet_mesh_renders_its_surface(stage, delegate):
    camera(stage)
    tm = UsdGeom.TetMesh.Define(stage, "/T")
    tm.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)])
    tm.CreateTetVertexIndicesAttr([Gf.Vec4i(0, 1, 2, 3), Gf.Vec4i(1, 2, 3, 4)])
    _, problems = load(stage, delegate)
    assert problems == []
    faces = floats(delegate.value("/T", "faceVertexIndices")).reshape(-1, 3)
    # two tetrahedra sharing the face (1, 2, 3): six outer faces, not the shared one
    assert len(faces) == 6
    assert sorted(map(sorted, faces.tolist())).count([1, 2, 3]) == 0
