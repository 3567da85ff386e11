"""Deformation motion blur, moving point instancers and native instances, and materialBind
GeomSubsets, end to end. What the reader sends is checked against values computed here from
USD's definitions (velocities in units per second, time codes per second); renders are checked
against the analytic streak length of a shape swept across the shutter and against the same
motion done by a transform.

Camera model (USD's): a point at depth z projects with F / -z / (AP / 2) * w / 2 px per unit.
"""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from conftest import (bind, camera, darkness, floats, fwhm, lambert_material, load, matrix, render,
                      settings)
from test_render import AP, F, _black, _px_per_unit_at, _white_dome

TCPS = 24.0


def _uv_sphere(radius, n=16):
    """Points, face counts and indices of a closed UV sphere mesh (quads and polar triangles)."""
    pts = [(0.0, radius, 0.0)]
    for i in range(1, n):
        th = math.pi * i / n
        for j in range(2 * n):
            ph = 2 * math.pi * j / (2 * n)
            pts.append((radius * math.sin(th) * math.cos(ph), radius * math.cos(th),
                        -radius * math.sin(th) * math.sin(ph)))
    pts.append((0.0, -radius, 0.0))
    ring = lambda i, j: 1 + (i - 1) * 2 * n + j % (2 * n)  # noqa: E731
    counts, idx = [], []
    for j in range(2 * n):
        counts.append(3)
        idx += [0, ring(1, j), ring(1, j + 1)]
    for i in range(1, n - 1):
        for j in range(2 * n):
            counts.append(4)
            idx += [ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)]
    last = len(pts) - 1
    for j in range(2 * n):
        counts.append(3)
        idx += [ring(n - 1, j + 1), ring(n - 1, j), last]
    return np.asarray(pts), counts, idx


def _mesh_ball(stage, path, radius, mat):
    pts, counts, idx = _uv_sphere(radius)
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreateFaceVertexCountsAttr(counts)
    m.CreateFaceVertexIndicesAttr(idx)
    m.CreateSubdivisionSchemeAttr("none")
    bind(m.GetPrim(), mat)
    return m, pts


def _vec3s(a):
    return [Gf.Vec3f(*map(float, p)) for p in a]


# -- what the reader sends --------------------------------------------------------------------
def _shutter_cam(stage, open_=0.0, close=1.0):
    camera(stage, **{"shutter__open": open_, "shutter__close": close})
    settings(stage)


def test_points_samples_with_another_count_are_a_problem_and_the_mesh_is_static(stage, delegate):
    _shutter_cam(stage)
    m, pts = _mesh_ball(stage, "/Blob", 0.5, _black(stage))
    m.GetPointsAttr().Set(_vec3s(pts), 0)
    m.GetPointsAttr().Set(_vec3s(pts[:-1] + 1.0), 1)
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Blob", "points")]
    # one value, the points at frame 0
    samples = delegate.samples("/Blob", "points")
    assert list(samples) == [None]
    assert np.allclose(floats(samples[None]), pts)


def test_points_sampled_only_outside_the_shutter_still_move_across_it(stage, delegate):
    # samples at frames 0 and 10; rendered at frame 5 with the shutter [0, 1]: USD interpolates,
    # so the points move 0.1 units per frame across the shutter and are sent at both its ends
    _shutter_cam(stage)
    m = UsdGeom.Mesh.Define(stage, "/Quad")
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad = np.array([(0, 0, -5), (1, 0, -5), (1, 1, -5), (0, 1, -5)], dtype=float)
    m.GetPointsAttr().Set(_vec3s(quad), 0)
    m.GetPointsAttr().Set(_vec3s(quad + (1.0, 0, 0)), 10)
    load(stage, delegate, frame=5)
    sent = delegate.samples("/Quad", "points")
    assert sorted(sent) == [0.0, 1.0], sent
    for t, shift in ((0.0, 0.5), (1.0, 0.6)):
        assert np.allclose(floats(sent[t]), quad + (shift, 0, 0), atol=1e-6)


@pytest.mark.parametrize("turn", [90.0, 180.0, 270.0, 360.0])
def test_a_child_of_a_turning_parent_is_sampled_along_its_arc(stage, delegate, turn):
    # the parent turns `turn` degrees about Y over the shutter (two samples, at its ends); USD
    # interpolates the angle, so the child 1.2 from the pivot runs along an arc. The reader
    # sends samples close enough that the renderer's rigid interpolation between them (chords)
    # stays on it: every sample on the circle at USD's angle, none more than 1/32 turn apart
    _shutter_cam(stage)
    parent = UsdGeom.Xform.Define(stage, "/Spin")
    op = parent.AddRotateYOp()
    op.Set(0.0, 0)
    op.Set(turn, 1)
    UsdGeom.Sphere.Define(stage, "/Spin/Ball").AddTranslateOp().Set(Gf.Vec3d(1.2, 0, 0))
    load(stage, delegate, frame=0)
    sent = delegate.samples("/Spin/Ball", "transform")
    times = sorted(sent)
    assert times[0] == 0.0 and times[-1] == 1.0
    gaps = np.diff(times)
    assert gaps.max() * turn <= 360.0 / 32 + 1e-9, (turn, times)
    for t in times:
        p = np.array([0, 0, 0, 1.0]) @ matrix(sent[t])
        angle = math.radians(turn * t)
        # rotateY: +x turns towards -z
        assert np.allclose(p[:3], [1.2 * math.cos(angle), 0, -1.2 * math.sin(angle)], atol=1e-6), (t, p)


def test_a_straight_move_needs_no_more_samples_than_its_ends(stage, delegate):
    _shutter_cam(stage)
    s = UsdGeom.Sphere.Define(stage, "/Ball")
    op = s.AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, -5), 0)
    op.Set(Gf.Vec3d(2, 0, -5), 1)
    load(stage, delegate, frame=0)
    assert sorted(delegate.samples("/Ball", "transform")) == [0.0, 1.0]


def test_mesh_velocities_and_accelerations_are_sent_and_checked(stage, delegate):
    _shutter_cam(stage)
    m, pts = _mesh_ball(stage, "/Blob", 0.5, _black(stage))
    m.GetPointsAttr().Set(_vec3s(pts))
    m.GetVelocitiesAttr().Set([Gf.Vec3f(48, 0, 0)] * len(pts))
    m.GetAccelerationsAttr().Set([Gf.Vec3f(0, 1, 0)] * 3)
    _, problems = load(stage, delegate)
    assert [(p.prim, p.attribute) for p in problems] == [("/Blob", "accelerations")]
    assert np.allclose(floats(delegate.value("/Blob", "velocities")), [48, 0, 0])


def _instancer(stage, path="/PI"):
    inst = UsdGeom.PointInstancer.Define(stage, path)
    UsdGeom.Sphere.Define(stage, path + "/Protos/Ball").CreateRadiusAttr(0.25)
    inst.CreatePrototypesRel().SetTargets([path + "/Protos/Ball"])
    inst.CreateProtoIndicesAttr([0, 0])
    inst.CreatePositionsAttr([(0, 0, -10), (0, 3, -10)])
    return inst


def _instance_samples(delegate, path):
    """[(frame offset, n x 4 x 4)] of the instanceTransforms sent."""
    got = delegate.samples(path, "instanceTransforms")
    return [(t, floats(got[t]).reshape(-1, 4, 4)) for t in sorted(got, key=lambda t: t or 0)]


def test_point_instancer_velocities_give_transform_samples_over_the_shutter(stage, delegate):
    _shutter_cam(stage, -0.25, 0.5)
    inst = _instancer(stage)
    inst.CreateVelocitiesAttr([(48, 0, 0), (0, -24, 0)])
    load(stage, delegate)
    got = _instance_samples(delegate, "/PI/proto0_Ball")
    assert [t for t, _ in got] == [-0.25, 0.5]
    # p(t) = p + v * t / tcps at the shutter's ends
    for t, mats in got:
        assert np.allclose(mats[0][3, :3], [48 * t / TCPS, 0, -10], atol=1e-6)
        assert np.allclose(mats[1][3, :3], [0, 3 - 24 * t / TCPS, -10], atol=1e-6)


def test_a_nested_instancer_moves_with_the_outer_instances(stage, delegate):
    """The outer instances' velocities carry the inner instancer's instances along: samples
    at the shutter's ends, each inner ball where its outer instance has moved it."""
    _shutter_cam(stage, -0.25, 0.5)
    outer = UsdGeom.PointInstancer.Define(stage, "/Field")
    UsdGeom.Xform.Define(stage, "/Field/Protos/Cluster")
    _instancer(stage, "/Field/Protos/Cluster/PI")
    outer.CreatePrototypesRel().SetTargets(["/Field/Protos/Cluster"])
    outer.CreateProtoIndicesAttr([0])
    outer.CreatePositionsAttr([(5, 0, 0)])
    outer.CreateVelocitiesAttr([(48, 0, 0)])
    _, problems = load(stage, delegate)
    assert problems == [], problems
    got = _instance_samples(delegate, "/Field/Protos/Cluster/PI/proto0_Ball")
    assert [t for t, _ in got] == [-0.25, 0.5]
    for t, mats in got:
        x = 5 + 48 * t / TCPS
        assert np.allclose([m[3, :3] for m in mats], [(x, 0, -10), (x, 3, -10)], atol=1e-6)


@pytest.mark.parametrize("count", [None, 9])
def test_point_instancer_angular_velocities_sweep_an_arc(stage, delegate, count):
    _shutter_cam(stage, 0.0, 1.0)
    inst = _instancer(stage)
    inst.CreateAngularVelocitiesAttr([(0, 0, 24 * 90.0), (0, 0, 0)])   # degrees per second
    if count:
        UsdGeom.MotionAPI.Apply(inst.GetPrim()).CreateNonlinearSampleCountAttr(count)
    load(stage, delegate)
    got = _instance_samples(delegate, "/PI/proto0_Ball")
    # 4 steps over the shutter (or the 8 that motion:nonlinearSampleCount 9 asks for); the
    # angle at offset t is 90° * t (one frame = 1/24 s)
    steps = (count or 5) - 1
    assert [t for t, _ in got] == [k / steps for k in range(steps + 1)]
    for t, mats in got:
        a = math.radians(90.0 * t)
        x_axis = mats[0][0, :3]
        assert np.allclose(x_axis, [math.cos(a), math.sin(a), 0], atol=1e-4), (t, x_axis)
        assert np.allclose(mats[1][:3, :3], np.eye(3), atol=1e-6)


def test_angular_velocities_turn_each_instance_about_its_own_position(stage, delegate):
    """Instances with their own orientations and scales, spun about tilted axes (one not at
    all) while they travel: at each key, Gf's own matrices (the instance's, moved to the
    origin, turned by |w| dt degrees about w, moved back), carried along by the velocity."""
    _shutter_cam(stage, -0.5, 0.5)
    inst = _instancer(stage)
    inst.CreateProtoIndicesAttr([0, 0, 0])
    inst.CreatePositionsAttr([(0, 0, -10), (0, 3, -10), (2, 1, -12)])
    inst.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0), Gf.Quath(0.8, 0.6, 0, 0), Gf.Quath(0.6, 0, 0, 0.8)])
    inst.CreateScalesAttr([(1, 1, 1), (2, 0.5, 1), (1, 3, 0.25)])
    omega = [(0, 0, 0), (300, -200, 100), (-50, 400, 250)]   # degrees per second
    inst.CreateAngularVelocitiesAttr(omega)
    inst.CreateVelocitiesAttr([(24, 0, 0)] * 3)
    _, problems = load(stage, delegate)
    assert problems == [], problems
    got = _instance_samples(delegate, "/PI/proto0_Ball")
    assert [t for t, _ in got] == [-0.5, -0.25, 0.0, 0.25, 0.5]
    base = inst.ComputeInstanceTransformsAtTime(Usd.TimeCode(1), Usd.TimeCode(1))
    for t, mats in got:
        dt = t / TCPS
        for i, w in enumerate(omega):
            m = Gf.Matrix4d(base[i])
            p = m.ExtractTranslation()
            deg = Gf.Vec3d(*w).GetLength() * dt
            if deg:
                m = m * Gf.Matrix4d().SetTranslate(-p) * Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(*w), deg)) * \
                    Gf.Matrix4d().SetTranslate(p + Gf.Vec3d(24 * dt, 0, 0))
            else:
                m = m * Gf.Matrix4d().SetTranslate(Gf.Vec3d(24 * dt, 0, 0))
            assert np.allclose(mats[i], np.array(m), atol=1e-5), (t, i, mats[i], m)
    # the turn is not the identity: the spun instances' axes move between the ends
    assert not np.allclose(got[0][1][1][:3, :3], got[-1][1][1][:3, :3], atol=0.1)


def test_a_meshs_nonlinear_sample_count_is_sent_with_its_accelerations(stage, delegate):
    """motion:nonlinearSampleCount (inherited from an ancestor) reaches the delegate with a
    mesh's accelerations, which it keys that many times."""
    _shutter_cam(stage, -0.5, 0.5)
    g = stage.DefinePrim("/G", "Xform")
    UsdGeom.MotionAPI.Apply(g).CreateNonlinearSampleCountAttr(7)
    m = UsdGeom.Mesh.Define(stage, "/G/M")
    m.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    m.CreateFaceVertexCountsAttr([3])
    m.CreateFaceVertexIndicesAttr([0, 1, 2])
    m.CreateAccelerationsAttr([(0, -10, 0)] * 3)
    load(stage, delegate)
    assert delegate.value("/G/M", "motion:nonlinearSampleCount") == 7


def test_time_sampled_positions_move_the_instances(stage, delegate):
    _shutter_cam(stage, 0.0, 1.0)
    inst = _instancer(stage)
    inst.GetPositionsAttr().Set([(0, 0, -10), (0, 3, -10)], 0)
    inst.GetPositionsAttr().Set([(2, 0, -10), (0, 3, -10)], 1)
    load(stage, delegate)
    got = _instance_samples(delegate, "/PI/proto0_Ball")
    assert [t for t, _ in got] == [0.0, 1.0]
    assert np.allclose(got[1][1][0][3, :3], [2, 0, -10])


# A stage with held interpolation keeps each value until its next sample: the reader sends a
# sample HELD_STEP of the shutter before each one inside it, still at the value before.
def _held_step(lo, hi):
    from tide.usd_reader import HELD_STEP
    return HELD_STEP * (hi - lo)


def test_a_held_stage_steps_a_transform_at_its_sample(stage, delegate):
    _shutter_cam(stage, 0.0, 1.0)
    s = UsdGeom.Sphere.Define(stage, "/Ball")
    op = s.AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, -5), 0)
    op.Set(Gf.Vec3d(1, 0, -5), 0.6)
    stage.SetInterpolationType(Usd.InterpolationTypeHeld)
    load(stage, delegate, frame=0)
    sent = delegate.samples("/Ball", "transform")
    d = _held_step(0.0, 1.0)
    assert sorted(sent) == [0.0, 0.6 - d, 0.6, 1.0], sorted(sent)
    for t, x in ((0.0, -1), (0.6 - d, -1), (0.6, 1), (1.0, 1)):
        assert np.allclose(matrix(sent[t])[3, :3], [x, 0, -5]), (t, matrix(sent[t]))


def test_a_held_stage_steps_points_and_instances_and_not_at_the_shutter_open(stage, delegate):
    _shutter_cam(stage, -0.25, 0.5)
    m = UsdGeom.Mesh.Define(stage, "/Quad")
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    quad = np.array([(0, 0, -5), (1, 0, -5), (1, 1, -5), (0, 1, -5)], dtype=float)
    # samples at the shutter's open (no step there) and inside it
    for t, dx in ((-0.25, 0.0), (0.25, 2.0)):
        m.GetPointsAttr().Set(_vec3s(quad + (dx, 0, 0)), t)
    inst = _instancer(stage)
    inst.GetPositionsAttr().Set([(0, 0, -10), (0, 3, -10)], -1)
    inst.GetPositionsAttr().Set([(2, 0, -10), (0, 3, -10)], 0.1)
    stage.SetInterpolationType(Usd.InterpolationTypeHeld)
    load(stage, delegate, frame=0)
    d = _held_step(-0.25, 0.5)
    pts = delegate.samples("/Quad", "points")
    assert sorted(pts) == [-0.25, 0.25 - d, 0.25, 0.5], sorted(pts)
    for t, dx in ((-0.25, 0), (0.25 - d, 0), (0.25, 2), (0.5, 2)):
        assert np.allclose(floats(pts[t]), quad + (dx, 0, 0)), t
    got = _instance_samples(delegate, "/PI/proto0_Ball")
    assert [t for t, _ in got] == [-0.25, 0.1 - d, 0.1, 0.5]
    assert [m[0][3, 0] for _, m in got] == [0, 0, 2, 2]


def test_setting_the_stage_interpolation_resends_the_samples(stage, delegate):
    _shutter_cam(stage, 0.0, 1.0)
    op = UsdGeom.Sphere.Define(stage, "/Ball").AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, -5), 0)
    op.Set(Gf.Vec3d(1, 0, -5), 0.5)
    reader, _ = load(stage, delegate, frame=0)
    assert sorted(delegate.samples("/Ball", "transform")) == [0.0, 0.5, 1.0]
    stage.SetInterpolationType(Usd.InterpolationTypeHeld)
    reader.update()
    assert len(delegate.samples("/Ball", "transform")) == 4
    stage.SetInterpolationType(Usd.InterpolationTypeLinear)
    reader.update()
    assert sorted(delegate.samples("/Ball", "transform")) == [0.0, 0.5, 1.0]


def test_native_instances_with_moving_roots_get_motion_samples(stage, delegate):
    _shutter_cam(stage, 0.0, 1.0)
    proto = stage.CreateClassPrim("/Proto")
    UsdGeom.Sphere.Define(stage, "/Proto/Ball")
    for i in range(2):
        p = stage.DefinePrim("/I%d" % i, "Xform")
        p.GetInherits().AddInherit(proto.GetPath())
        p.SetInstanceable(True)
        op = UsdGeom.Xformable(p).AddTranslateOp()
        op.Set(Gf.Vec3d(5 * i, 0, -10), 0)
        op.Set(Gf.Vec3d(5 * i + (1 if i == 0 else 0), 0, -10), 1)
    load(stage, delegate)
    [path] = delegate.of_type("sphere")
    got = _instance_samples(delegate, path)
    assert [t for t, _ in got] == [0.0, 1.0]
    # the instance at x = 0 moves to x = 1, the one at x = 5 stays
    assert sorted(got[0][1][:, 3, 0]) == [0, 5]
    assert sorted(got[1][1][:, 3, 0]) == [1, 5]


def test_native_instance_prototype_motion_is_in_its_transform(stage, delegate):
    _shutter_cam(stage, 0.0, 1.0)
    proto = stage.CreateClassPrim("/Proto")
    ball = UsdGeom.Sphere.Define(stage, "/Proto/Ball")
    op = ball.AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 0)
    op.Set(Gf.Vec3d(0, 2, 0), 1)
    p = stage.DefinePrim("/I0", "Xform")
    p.GetInherits().AddInherit(proto.GetPath())
    p.SetInstanceable(True)
    UsdGeom.Xformable(p).AddTranslateOp().Set(Gf.Vec3d(0, 0, -10))
    load(stage, delegate)
    [path] = delegate.of_type("sphere")
    xf = delegate.samples(path, "transform")
    assert sorted(xf) == [0.0, 1.0]
    assert np.allclose(np.asarray(xf[1.0][1]).reshape(4, 4)[3, :3], [0, 2, 0])
    # the instance root does not move
    assert list(delegate.samples(path, "instanceTransforms")) == [None]


def _two_subset_cube(stage, path="/Cube", collection=True):
    """A cube mesh of half-size 1 (faces: 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z) with a red
    subset on +X bound directly and a green subset on +Z bound through a collection on the
    mesh (or directly); the mesh itself is grey."""
    v = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    k = {p: i for i, p in enumerate(v)}
    faces = [
        [(1, -1, -1), (1, 1, -1), (1, 1, 1), (1, -1, 1)],
        [(-1, -1, -1), (-1, -1, 1), (-1, 1, 1), (-1, 1, -1)],
        [(-1, 1, -1), (-1, 1, 1), (1, 1, 1), (1, 1, -1)],
        [(-1, -1, -1), (1, -1, -1), (1, -1, 1), (-1, -1, 1)],
        [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],
        [(-1, -1, -1), (-1, 1, -1), (1, 1, -1), (1, -1, -1)],
    ]
    UsdGeom.Xform.Define(stage, "/World")
    m = UsdGeom.Mesh.Define(stage, "/World" + path)
    m.CreatePointsAttr([Gf.Vec3f(*p) for p in v])
    m.CreateFaceVertexCountsAttr([4] * 6)
    m.CreateFaceVertexIndicesAttr([k[p] for f in faces for p in f])
    m.CreateSubdivisionSchemeAttr("none")
    grey = lambert_material(stage, "/Looks/Grey", (0.5, 0.5, 0.5))
    red = lambert_material(stage, "/Looks/Red", (0.8, 0.05, 0.05))
    green = lambert_material(stage, "/Looks/Green", (0.05, 0.8, 0.05))
    bind(m.GetPrim(), grey)
    img = UsdGeom.Imageable(m)
    a = UsdGeom.Subset.CreateGeomSubset(img, "red", UsdGeom.Tokens.face, [0], "materialBind")
    b = UsdGeom.Subset.CreateGeomSubset(img, "green", UsdGeom.Tokens.face, [4], "materialBind")
    bind(a.GetPrim(), red)
    if collection:
        # on the mesh: walking up from the subset, the mesh's collection bindings come
        # before its direct (grey) binding
        coll = Usd.CollectionAPI.Apply(m.GetPrim(), "greens")
        coll.CreateIncludesRel().AddTarget(b.GetPath())
        UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(coll, green, "greenBinding")
    else:
        bind(b.GetPrim(), green)
    return m, a, b


def test_material_bind_subsets_are_sent_with_resolved_materials(stage, delegate):
    camera(stage)
    settings(stage)
    _two_subset_cube(stage)
    _, problems = load(stage, delegate)
    assert problems == []
    sent = delegate.value("/World/Cube", "geomSubsets")
    assert list(sent[1]) == ["/World/Cube/red", "/World/Cube/green"]
    assert delegate.value("/World/Cube", "/World/Cube/red.material")[1] == "/Looks/Red"
    # the collection-based binding reaches the subset
    assert delegate.value("/World/Cube", "/World/Cube/green.material")[1] == "/Looks/Green"
    assert list(floats(delegate.value("/World/Cube", "/World/Cube/green.indices"))) == [4]


# -- renders ----------------------------------------------------------------------------------
W, H = 128, 16


def _streak(renderer, stage):
    """FWHM (px) of the darkness along the middle rows of a render against a white dome."""
    settings(stage, res=(W, H), samples=256)
    d = darkness(render(renderer, stage, frame=0)["color"])
    return fwhm(d[H // 2 - 1:H // 2 + 1].mean(axis=0))


def _scene(stage):
    camera(stage, focal=F, aperture=(AP, AP * H / W),
           **{"shutter__open": 0.0, "shutter__close": 1.0})
    _white_dome(stage)
    return _black(stage)


def _deformed(stage):
    m, pts = _mesh_ball(stage, "/Ball", 0.25, _scene(stage))
    at = lambda x: _vec3s(pts + np.array([x, 0.0, -10.0]))  # noqa: E731
    m.GetPointsAttr().Set(at(-1.0), 0)
    m.GetPointsAttr().Set(at(1.0), 1)


def _transformed(stage):
    m, pts = _mesh_ball(stage, "/Ball", 0.25, _scene(stage))
    m.GetPointsAttr().Set(_vec3s(pts))
    op = m.AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, -10), 0)
    op.Set(Gf.Vec3d(1, 0, -10), 1)


def _by_velocity(stage):
    m, pts = _mesh_ball(stage, "/Ball", 0.25, _scene(stage))
    m.GetPointsAttr().Set(_vec3s(pts + np.array([-1.0, 0.0, -10.0])))
    # 2 units over one frame at 24 frames per second
    m.GetVelocitiesAttr().Set([Gf.Vec3f(2 * TCPS, 0, 0)] * len(pts))


# A ball of diameter D swept over L >= D darkens a trapezoid whose full width at half maximum
# is L: 2 units at z = -10. 256 spp: per-pixel coverage noise ~2.7 %, ramps ~3 %/px, so each
# crossing is found to ~1 px (the tolerance of the transform-blur test in test_render.py).
EXPECT = 2.0 * _px_per_unit_at(-10.0, W)


def test_deforming_mesh_streaks_as_far_as_the_same_motion_by_transform(renderer):
    lengths = {}
    for name, build in (("points", _deformed), ("transform", _transformed),
                        ("velocities", _by_velocity)):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        build(s)
        lengths[name] = _streak(renderer, s)
    for name, length in lengths.items():
        assert length == pytest.approx(EXPECT, abs=1.5), (name, lengths)
    # the three motions agree with each other more closely than with the analytic value's
    # tolerance: same sampler, same sweep; 1.5 px still allows both crossings' noise
    assert abs(lengths["points"] - lengths["transform"]) < 1.5, lengths
    assert abs(lengths["velocities"] - lengths["points"]) < 1.5, lengths


def test_deformation_blur_is_off_without_motion_blur(renderer, stage):
    _deformed(stage)
    st = settings(stage, res=(W, H), samples=256)
    st.GetPrim().CreateAttribute("disableMotionBlur", Sdf.ValueTypeNames.Bool).Set(True)
    d = darkness(render(renderer, stage, frame=0)["color"])
    row = d[H // 2 - 1:H // 2 + 1].mean(axis=0)
    width = np.count_nonzero(row > row.max() / 2)
    # a still ball (diameter 0.5 units at frame 0): ~5.6 px wide, far from the 22 px streak
    assert width <= 0.5 * _px_per_unit_at(-10.0, W) + 2


def test_point_instancer_velocity_streaks_by_v_times_shutter(renderer, stage):
    black = _scene(stage)
    inst = UsdGeom.PointInstancer.Define(stage, "/PI")
    ball = UsdGeom.Sphere.Define(stage, "/PI/Protos/Ball")
    ball.CreateRadiusAttr(0.25)
    bind(ball.GetPrim(), black)
    inst.CreatePrototypesRel().SetTargets(["/PI/Protos/Ball"])
    inst.CreateProtoIndicesAttr([0])
    inst.CreatePositionsAttr([(-1, 0, -10)])
    v = 2 * TCPS                         # 2 units over the one-frame shutter
    inst.CreateVelocitiesAttr([(v, 0, 0)])
    assert _streak(renderer, stage) == pytest.approx(v / TCPS * _px_per_unit_at(-10.0, W),
                                                     abs=1.5)


def test_a_held_jump_shows_the_ball_at_both_places_by_the_time_it_spent_there(renderer, stage):
    # a black ball held at x = -1 until 0.6 of the shutter, then at x = +1: each place is
    # covered for its share of the exposure (0.6 and 0.4) and nothing lies between them
    black = _scene(stage)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr(0.25)
    bind(ball.GetPrim(), black)
    op = ball.AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, -10), 0)
    op.Set(Gf.Vec3d(1, 0, -10), 0.6)
    stage.SetInterpolationType(Usd.InterpolationTypeHeld)
    settings(stage, res=(W, H), samples=256)
    d = darkness(render(renderer, stage, frame=0)["color"])
    rows = d[H // 2 - 1:H // 2 + 1]
    px = _px_per_unit_at(-10.0, W)
    at = lambda x: rows[:, int(W / 2 + x * px) - 1:int(W / 2 + x * px) + 1].mean()  # noqa: E731
    # 4 pixels of 256 samples each: coverage noise sqrt(0.24 / 1024) ~ 0.015
    assert at(-1) == pytest.approx(0.6, abs=0.06)
    assert at(1) == pytest.approx(0.4, abs=0.06)
    assert at(0) < 0.02
    # the whole ball's darkness is kept: the two images sum to one still ball's
    still = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(still, UsdGeom.Tokens.y)
    b = UsdGeom.Sphere.Define(still, "/Ball")
    b.CreateRadiusAttr(0.25)
    bind(b.GetPrim(), _scene(still))
    b.AddTranslateOp().Set(Gf.Vec3d(-1, 0, -10))
    settings(still, res=(W, H), samples=256)
    total = darkness(render(renderer, still, frame=0)["color"]).sum()
    assert d.sum() == pytest.approx(total, rel=0.05)


def test_cube_subsets_show_their_colours_on_their_faces(renderer, stage):
    w = h = 64
    # looking at the cube's +X / +Z corner from above: faces +X, +Y and +Z are in view
    cam = camera(stage, focal=F, aperture=(AP, AP))
    xf = UsdGeom.Xformable(cam)
    xf.ClearXformOpOrder()
    eye = Gf.Vec3d(6, 5, 6)
    look = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0)).GetInverse()
    xf.AddTransformOp().Set(look)
    _white_dome(stage)
    _two_subset_cube(stage)
    settings(stage, res=(w, h), samples=32, vars_=("color", "normal"))
    out = render(renderer, stage)
    rgb, n = out["color"][..., :3], out["normal"][..., :3]
    expected = {(1, 0, 0): "red", (0, 0, 1): "green", (0, 1, 0): "grey"}
    for axis, name in expected.items():
        sel = np.all(np.abs(n - np.array(axis, dtype=np.float32)) < 0.05, axis=-1)
        # each face covers a few hundred pixels at this size
        assert sel.sum() > 100, (name, sel.sum())
        c = rgb[sel].mean(axis=0)
        # a convex face under a uniform white dome reflects albedo * (1 - F) + F, F the share
        # the preview surface's specular layer reflects at this view (about 0.2 here: the grey
        # face reads ~0.6). Red (0.8, 0.05, 0.05) then gives r / g = 0.84 / 0.24 = 3.5, still
        # above 3 for any F < 0.25, and green likewise; grey stays achromatic (channels within
        # 3 %: uplifting round-off and 32 spp of a smooth integrand)
        if name == "red":
            assert c[0] > 3 * c[1] and c[0] > 3 * c[2], c
        elif name == "green":
            assert c[1] > 3 * c[0] and c[1] > 3 * c[2], c
        else:
            assert c.max() < 1.03 * c.min() and 0.45 < c.mean() < 0.7, c


def test_bad_subset_indices_are_reported_and_ignored(renderer, stage):
    from tide import usd_reader
    camera(stage)
    settings(stage, res=(8, 8), samples=1)
    _, a, _ = _two_subset_cube(stage, collection=False)
    a.GetIndicesAttr().Set([0, 6, 99])
    r = usd_reader.Reader(stage, renderer.RenderDelegate())
    problems = [p for p in r.load() if p.prim.startswith("/World")]
    assert [(p.prim, p.attribute) for p in problems] == [("/World/Cube/red", "indices")]
    assert "2 face index(es) out of range" in problems[0].message
