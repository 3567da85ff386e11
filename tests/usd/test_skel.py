"""Skinned meshes (UsdSkel) through the reader: what reaches the delegate is the posed mesh,
in the skeleton's space and placed by the Skeleton's transform, checked against poses computed
here by hand (a vertex bound to a joint turns about the joint's position by the joint's
animated angle), independently of UsdSkel.

The rig: /World (translated by (0, 0, -5)) / Char (SkelRoot) / Skel (translated by (0, 2, 0)),
joints `root` at the skeleton's origin and `root/tip` at (1, 0, 0). The mesh is a strip of two
quads, x in {0, 1, 2} and y in {0, 1}; the two vertices at x = 2 follow `tip`, the rest follow
`root`. The animation turns `tip` about Z by 90 degrees at time 0 and by 0 at time 1. The mesh
has a transform of its own, which a skinned mesh does not use.
"""
import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdSkel

from conftest import bind, camera, darkness, floats, load, matrix, render, settings
from test_render import _black, _project, _white_dome

STRIP = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
TIP = (1.0, 0.0, 0.0)                   # the `tip` joint's position in skeleton space
MESH = "/World/Char/Mesh"
SKEL_WORLD = (0.0, 2.0, -5.0)           # the skeleton's translation in the world


def _quat_z(deg):
    return Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), deg).GetQuat())


def _rig(stage, anim=True, rest=True, indices=(0, 0, 1, 0, 0, 1), geom_bind=True):
    UsdGeom.Xform.Define(stage, "/World").AddTranslateOp().Set(Gf.Vec3d(0, 0, -5))
    UsdSkel.Root.Define(stage, "/World/Char")
    skel = UsdSkel.Skeleton.Define(stage, "/World/Char/Skel")
    skel.AddTranslateOp().Set(Gf.Vec3d(0, 2, 0))
    skel.CreateJointsAttr(["root", "root/tip"])
    tip = Gf.Matrix4d().SetTranslate(Gf.Vec3d(*TIP))
    skel.CreateBindTransformsAttr([Gf.Matrix4d(1), tip])
    if rest:
        skel.CreateRestTransformsAttr([Gf.Matrix4d(1), tip])
    mesh = UsdGeom.Mesh.Define(stage, MESH)
    mesh.CreatePointsAttr(STRIP)
    mesh.CreateFaceVertexCountsAttr([4, 4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 4, 3, 1, 2, 5, 4])
    mesh.CreateSubdivisionSchemeAttr("none")
    mesh.AddTranslateOp().Set(Gf.Vec3d(10, 10, 10))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(False, 1).Set(list(indices))
    binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * len(indices))
    if geom_bind:
        binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    if anim:
        a = UsdSkel.Animation.Define(stage, "/World/Char/Anim")
        a.CreateJointsAttr(["root/tip"])
        a.CreateTranslationsAttr([Gf.Vec3f(*TIP)])
        a.CreateScalesAttr([Gf.Vec3h(1, 1, 1)])
        rot = a.CreateRotationsAttr()
        rot.Set([_quat_z(90)], 0)
        rot.Set([_quat_z(0)], 1)
        UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets(
            [a.GetPath()])
    return mesh


def _turned(p, deg, about=TIP):
    """`p` turned about the Z axis through `about` by `deg` degrees."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    x, y = p[0] - about[0], p[1] - about[1]
    return (about[0] + c * x - s * y, about[1] + s * x + c * y, p[2])


def _posed(deg):
    """The strip with the vertices at x = 2 turned with `tip`."""
    return np.asarray([_turned(p, deg) if p[0] == 2 else p for p in STRIP], dtype=np.float64)


def _translation(value):
    m = matrix(value)
    assert np.allclose(m[:3, :3], np.eye(3))
    return m[3, :3]


def _scene(stage, **rig):
    camera(stage)
    settings(stage)
    return _rig(stage, **rig)


# -- the posed mesh -------------------------------------------------------------------------
def test_posed_points_at_a_frame_in_the_skeletons_space(stage, delegate):
    _scene(stage)
    for frame, deg in ((0, 90), (0.5, 45), (1, 0)):
        d = type(delegate)()
        _, problems = load(stage, d, frame=frame)
        assert problems == []
        assert d.prims[MESH] == "mesh"
        assert list(d.samples(MESH, "points")) == [None]
        assert np.allclose(floats(d.value(MESH, "points")), _posed(deg), atol=1e-5), frame
        # the Skeleton's world transform, not the mesh's own (which would add (10, 10, 10))
        assert np.allclose(_translation(d.value(MESH, "transform")), SKEL_WORLD)


def test_skinning_inputs_are_not_sent(stage, delegate):
    _scene(stage)
    load(stage, delegate, frame=0)
    # the binding's primvars are skinning inputs
    assert sorted(delegate.primvars.get(MESH, {})) == []
    # the skeleton is not a gprim of its own
    assert sorted(delegate.of_type("mesh")) == [MESH]


def _normals_sent(delegate):
    interp, data, tsize, idx = delegate.primvars[MESH]["normals"]
    assert tsize == 3 and idx is None
    n = np.asarray(data, dtype=np.float64).reshape(-1, 3)
    return interp, n / np.linalg.norm(n, axis=1, keepdims=True)


def test_authored_normals_turn_with_their_joints(stage, delegate):
    """Normals (1, 0, 0) everywhere: those of the points that follow `tip` (2 and 5) turn
    with it by 90 degrees about Z, the rest stay, per point and per face corner, with linear
    blend and with dual quaternion skinning alike."""
    mesh = _scene(stage)
    want_points = np.asarray([(0, 1, 0) if i in (2, 5) else (1, 0, 0) for i in range(6)], float)
    corners = [0, 1, 4, 3, 1, 2, 5, 4]
    for method in ("classicLinear", "dualQuaternion"):
        UsdSkel.BindingAPI(mesh.GetPrim()).CreateSkinningMethodAttr().Set(method)
        for interp, count, want in (("vertex", 6, want_points),
                                    ("faceVarying", 8, want_points[corners])):
            mesh.CreateNormalsAttr([(1, 0, 0)] * count)
            mesh.SetNormalsInterpolation(interp)
            d = type(delegate)()
            _, problems = load(stage, d, frame=0)
            assert problems == []
            got_interp, got = _normals_sent(d)
            assert got_interp == interp
            assert np.allclose(got, want, atol=1e-5), (method, interp, got)


def test_blend_shape_normal_offsets_apply_before_skinning(stage, delegate):
    """A shape lifting point 2's normal by (0, 0, 1) at weight 0.5: (1, 0, 0.5), then turned
    with `tip` to (0, 1, 0.5) (normalised); a target without normalOffsets leaves normals as
    authored."""
    mesh = _scene(stage)
    mesh.CreateNormalsAttr([(1, 0, 0)] * 6)
    mesh.SetNormalsInterpolation("vertex")
    shape = _lift(stage, mesh)
    want = np.asarray([(0, 1, 0) if i in (2, 5) else (1, 0, 0) for i in range(6)], float)
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    assert np.allclose(_normals_sent(delegate)[1], want, atol=1e-5)
    shape.CreateNormalOffsetsAttr([Gf.Vec3f(0, 0, 1)])
    d = type(delegate)()
    _, problems = load(stage, d, frame=0)
    assert problems == []
    want[2] = np.asarray((0, 1, 0.5)) / np.linalg.norm((0, 1, 0.5))
    assert np.allclose(_normals_sent(d)[1], want, atol=1e-5)
    # face-varying normals: the joints turn them, the offsets do not (as UsdSkel bakes them)
    mesh.CreateNormalsAttr([(1, 0, 0)] * 8)
    mesh.SetNormalsInterpolation("faceVarying")
    d = type(delegate)()
    _, problems = load(stage, d, frame=0)
    assert problems == []
    bake_stage = Usd.Stage.CreateInMemory()
    bake_stage.GetRootLayer().TransferContent(stage.Flatten())
    assert UsdSkel.BakeSkinning(bake_stage.Traverse(), Gf.Interval(0, 0))
    baked = np.asarray(UsdGeom.Mesh(bake_stage.GetPrimAtPath(MESH)).GetNormalsAttr().Get(0), float)
    sent = _normals_sent(d)[1]
    assert np.allclose(sent, baked / np.linalg.norm(baked, axis=1, keepdims=True), atol=1e-5), (sent, baked)
    mesh.CreateNormalsAttr([(1, 0, 0)] * 6)
    mesh.SetNormalsInterpolation("vertex")
    # normalOffsets that do not fit the offsets: reported, and normals left to the core
    shape.CreateNormalOffsetsAttr([Gf.Vec3f(0, 0, 1)] * 2)
    d = type(delegate)()
    _, problems = load(stage, d, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [(MESH + "/Lift", "normalOffsets")]
    assert "normals" not in d.primvars.get(MESH, {})


def test_uniform_normals_of_a_skinned_mesh_are_reported_and_left_to_the_core(stage, delegate):
    mesh = _scene(stage)
    mesh.CreateNormalsAttr([(0, 0, 1)] * 2)
    mesh.SetNormalsInterpolation("uniform")
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [(MESH, "normals")]
    assert "normals" not in delegate.primvars.get(MESH, {})


def test_bind_pose_without_animation(stage, delegate):
    mesh = _scene(stage, anim=False)
    # geomBindTransform places the mesh in the skeleton's space at bind time
    UsdSkel.BindingAPI(mesh.GetPrim()).GetGeomBindTransformAttr().Set(
        Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 0, 1)))
    _, problems = load(stage, delegate)
    assert problems == []
    assert np.allclose(floats(delegate.value(MESH, "points")),
                       np.asarray(STRIP) + (0, 0, 1), atol=1e-6)
    assert np.allclose(_translation(delegate.value(MESH, "transform")), SKEL_WORLD)


def test_rigid_influences_move_every_point_with_their_joint(stage, delegate):
    mesh = _scene(stage)
    binding = UsdSkel.BindingAPI(mesh.GetPrim())
    binding.GetJointIndicesPrimvar().SetInterpolation("constant")
    binding.GetJointIndicesPrimvar().Set([1])
    binding.GetJointWeightsPrimvar().SetInterpolation("constant")
    binding.GetJointWeightsPrimvar().Set([1.0])
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    assert np.allclose(floats(delegate.value(MESH, "points")),
                       [_turned(p, 90) for p in STRIP], atol=1e-5)


def _lift(stage, mesh):
    """A blend shape lifting point 2 by (0, 0, 1), animated at weight 0.5."""
    shape = UsdSkel.BlendShape.Define(stage, MESH + "/Lift")
    shape.CreateOffsetsAttr([Gf.Vec3f(0, 0, 1)])
    shape.CreatePointIndicesAttr([2])
    binding = UsdSkel.BindingAPI(mesh.GetPrim())
    binding.CreateBlendShapesAttr(["lift"])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])
    anim = UsdSkel.Animation(stage.GetPrimAtPath("/World/Char/Anim"))
    anim.CreateBlendShapesAttr(["lift"])
    anim.CreateBlendShapeWeightsAttr([0.5])
    return shape


def test_blend_shapes_apply_before_skinning(stage, delegate):
    mesh = _scene(stage)
    _lift(stage, mesh)
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    want = _posed(90)
    # vertex 2 lifted by half the offset, then turned with `tip` (the turn keeps z)
    want[2] = _turned((2, 0, 0.5), 90)
    assert np.allclose(floats(delegate.value(MESH, "points")), want, atol=1e-5)


# -- motion over the shutter ----------------------------------------------------------------
@pytest.mark.parametrize("geom_bind", [True, False])
def test_posed_points_are_sampled_over_the_shutter(stage, delegate, geom_bind):
    # geomBindTransform is optional (identity): without it the mesh is posed all the same
    camera(stage, **{"shutter__open": -0.25, "shutter__close": 0.5})
    settings(stage)
    _rig(stage, geom_bind=geom_bind)
    skel = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Char/Skel"))
    # the skeleton moves too: its transform gets samples of its own
    skel.GetOrderedXformOps()[0].Set(Gf.Vec3d(0, 2, 0), -1)
    skel.GetOrderedXformOps()[0].Set(Gf.Vec3d(0, 4, 0), 1)
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    got = delegate.samples(MESH, "points")
    # the shutter's ends and the animation's key at 0 within it; rotations are held before
    # the first key and interpolated between keys (about one axis: the angle, linearly).
    # From 0 to 0.5 `tip` turns by 45 degrees: in eight steps of 5.6 (under 0.1 radians),
    # so that the turned vertices follow their arc (a chord of 45 degrees at 1.41 from the
    # joint passes 0.11 inside it; one of 5.6, 1.7e-3)
    steps = math.ceil(math.radians(45) / 0.1)
    assert steps == 8
    want = [-0.25, 0.0] + [0.5 * k / steps for k in range(1, steps + 1)]
    assert np.allclose(sorted(got), want, atol=1e-12), sorted(got)
    for t in got:
        deg = 90 if t <= 0 else 90 * (1 - t)
        assert np.allclose(floats(got[t]), _posed(deg), atol=1e-5), t
    xf = delegate.samples(MESH, "transform")
    assert sorted(xf) == [-0.25, 0.5]
    for t in xf:
        # y from 2 at time -1 to 4 at time 1
        assert np.allclose(_translation(xf[t]), (0, 3 + t, -5)), t
    assert delegate.samples(MESH, "velocities") == {}


def test_a_still_pose_is_one_sample_with_motion_blur_on(stage, delegate):
    camera(stage, **{"shutter__open": 0.0, "shutter__close": 0.5})
    settings(stage)
    _rig(stage, anim=False)
    load(stage, delegate)
    assert list(delegate.samples(MESH, "points")) == [None]


# -- problems -------------------------------------------------------------------------------
def test_joint_index_out_of_range_is_a_problem_and_the_mesh_renders_unskinned(stage, delegate):
    _scene(stage, indices=(0, 0, 5, 0, 0, 1))
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [
        (MESH, "primvars:skel:jointIndices")]
    assert "5" in problems[0].message and "2 joints" in problems[0].message
    assert delegate.prims[MESH] == "mesh"
    assert np.allclose(floats(delegate.value(MESH, "points")), STRIP)
    # its own transform: (10, 10, 10) under /World's (0, 0, -5)
    assert np.allclose(_translation(delegate.value(MESH, "transform")), (10, 10, 5))


@pytest.mark.parametrize("bad", ["translations", "rotations", "joints"])
def test_an_animation_or_joint_list_usdskel_cannot_use_is_a_problem(stage, delegate, bad):
    """UsdSkel only warns (and poses nothing, or leaves influences out) when a SkelAnimation's
    translations are not one per joint, its rotations have no value, or a mesh's skel:joints
    names a joint the Skeleton lacks: each is reported with its prim and attribute, and the
    points are still UsdSkel's."""
    mesh = _scene(stage)
    anim = UsdSkel.Animation(stage.GetPrimAtPath("/World/Char/Anim"))
    if bad == "translations":
        anim.GetTranslationsAttr().Set([Gf.Vec3f(*TIP)] * 3)
        where = ("/World/Char/Anim", "translations")
    elif bad == "rotations":
        anim.GetRotationsAttr().Block()
        where = ("/World/Char/Anim", "rotations")
    else:
        UsdSkel.BindingAPI(mesh.GetPrim()).CreateJointsAttr(["root", "nope"])
        where = (MESH, "skel:joints")
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [where], problems
    cache = UsdSkel.Cache()
    cache.Populate(UsdSkel.Root(stage.GetPrimAtPath("/World/Char")), Usd.PrimDefaultPredicate)
    query = cache.GetSkinningQuery(mesh.GetPrim())
    skel_query = cache.GetSkelQuery(UsdSkel.Skeleton(stage.GetPrimAtPath("/World/Char/Skel")))
    pts = mesh.GetPointsAttr().Get(0)
    query.ComputeSkinnedPoints(skel_query.ComputeSkinningTransforms(0), pts, 0)
    assert np.allclose(floats(delegate.value(MESH, "points")), np.asarray(pts), atol=1e-5)


def test_mismatched_weights_are_a_problem(stage, delegate):
    mesh = _scene(stage)
    UsdSkel.BindingAPI(mesh.GetPrim()).GetJointWeightsPrimvar().Set([1.0] * 5)
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [
        (MESH, "primvars:skel:jointWeights")]
    assert np.allclose(floats(delegate.value(MESH, "points")), STRIP)


def test_a_skeleton_without_a_pose_is_a_problem_on_the_skeleton(stage, delegate):
    # the animation drives `tip` only: `root` needs restTransforms, which are missing
    _scene(stage, rest=False)
    _, problems = load(stage, delegate, frame=0)
    assert [(p.prim, p.attribute) for p in problems] == [
        ("/World/Char/Skel", "restTransforms")]
    assert np.allclose(floats(delegate.value(MESH, "points")), STRIP)
    assert np.allclose(_translation(delegate.value(MESH, "transform")), (10, 10, 5))


def test_skinned_meshes_in_native_instances_are_posed_each_apart(stage, delegate):
    """Two instanceable references to the rig at (0, 0, 0) and (3, 0, 0) (their own translate
    replaces the referenced one): each instance's mesh is sent at its instance proxy's path,
    posed, and placed by that instance's skeleton, (0, 2, 0) above the instance."""
    _scene(stage)
    for name, x in (("A", 0.0), ("B", 3.0)):
        inst = UsdGeom.Xform.Define(stage, "/Inst" + name)
        inst.AddTranslateOp().Set(Gf.Vec3d(x, 0, 0))
        inst.GetPrim().GetReferences().AddInternalReference("/World")
        inst.GetPrim().SetInstanceable(True)
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    for mesh, skel in ((MESH, SKEL_WORLD), ("/InstA/Char/Mesh", (0, 2, 0)),
                       ("/InstB/Char/Mesh", (3, 2, 0))):
        assert np.allclose(floats(delegate.value(mesh, "points")), _posed(90), atol=1e-5), mesh
        assert np.allclose(_translation(delegate.value(mesh, "transform")), skel), mesh


def test_a_skinned_prototype_of_a_point_instancer_is_posed_once(stage, delegate):
    """The rig as a point instancer's prototype, placed at (0, 0, 0) and (0, 4, 0): its mesh
    is posed by its skeleton, placed relative to the prototype's parent (the instancer), and
    the instances place that one pose."""
    _scene(stage)
    pi = UsdGeom.PointInstancer.Define(stage, "/Crowd")
    proto = stage.DefinePrim("/Crowd/Protos/Agent", "Xform")
    proto.GetReferences().AddInternalReference("/World")
    pi.CreatePrototypesRel().SetTargets([proto.GetPath()])
    pi.CreateProtoIndicesAttr([0, 0])
    pi.CreatePositionsAttr([(0, 0, 0), (0, 4, 0)])
    _, problems = load(stage, delegate, frame=0)
    assert problems == []
    agent = [p for p in delegate.of_type("mesh") if p.startswith("/Crowd/")]
    assert len(agent) == 1, agent
    assert np.allclose(floats(delegate.value(agent[0], "points")), _posed(90), atol=1e-5)
    # the skeleton sits at (0, 2, -5) under the prototype, which sits at the instancer's origin
    assert np.allclose(_translation(delegate.value(agent[0], "transform")), SKEL_WORLD)
    xf = floats(delegate.value(agent[0], "instanceTransforms")).reshape(-1, 4, 4)
    assert np.allclose(xf[:, 3, :3], [(0, 0, 0), (0, 4, 0)])


def test_problems_are_reported_once(stage, delegate):
    _scene(stage, indices=(0, 0, 5, 0, 0, 1))
    reader, problems = load(stage, delegate, frame=0)
    assert len(problems) == 1
    assert reader.select_render(0) == []


# -- edits ----------------------------------------------------------------------------------
def test_editing_the_animation_resends_the_posed_points(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate, frame=0)
    assert np.allclose(floats(delegate.value(MESH, "points")), _posed(90), atol=1e-5)
    anim = UsdSkel.Animation(stage.GetPrimAtPath("/World/Char/Anim"))
    anim.GetRotationsAttr().Set([_quat_z(180)], 0)
    assert reader.update() == []
    assert MESH in delegate.last_synced()
    assert np.allclose(floats(delegate.value(MESH, "points")), _posed(180), atol=1e-5)


def test_moving_the_skeleton_moves_the_mesh(stage, delegate):
    _scene(stage)
    reader, _ = load(stage, delegate, frame=0)
    skel = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Char/Skel"))
    skel.GetOrderedXformOps()[0].Set(Gf.Vec3d(3, 2, 0))
    reader.update()
    assert delegate.last_synced() == [MESH]
    assert np.allclose(_translation(delegate.value(MESH, "transform")), (3, 2, -5))


def test_editing_the_joint_indices_resends_the_posed_points(stage, delegate):
    mesh = _scene(stage)
    reader, _ = load(stage, delegate, frame=0)
    # every vertex on `root`: the strip as authored
    UsdSkel.BindingAPI(mesh.GetPrim()).GetJointIndicesPrimvar().Set([0] * 6)
    reader.update()
    assert delegate.last_synced() == [MESH]
    assert np.allclose(floats(delegate.value(MESH, "points")), STRIP, atol=1e-6)


# -- rendered -------------------------------------------------------------------------------
def test_the_posed_strip_renders_where_the_skeleton_puts_it(renderer):
    """Against a white dome, the black strip covers the pixels the hand-posed strip projects
    to: the quad that `tip` folds away at frame 0 is there at frame 1 only."""
    seen = {}
    for frame in (0, 1):
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        camera(stage, focal=50.0, aperture=(36.0, 36.0))
        settings(stage, res=(32, 32), samples=16)
        _white_dome(stage)
        mesh = _rig(stage)
        bind(mesh.GetPrim(), _black(stage))
        # the skeleton at (-1, -0.5, -5) in the world: the strip straddles the view's centre
        UsdGeom.Xformable(stage.GetPrimAtPath("/World/Char/Skel")).GetOrderedXformOps()[0].Set(
            Gf.Vec3d(-1, -0.5, 0))
        d = darkness(render(renderer, stage, frame=frame)["color"])

        def at(sx, sy):
            col, row = _project(sx - 1, sy - 0.5, -5.0, 32, 32)
            c, r = int(col), int(row)
            return float(d[r - 1:r + 2, c - 1:c + 2].mean())

        seen[frame] = (at(0.5, 0.5), at(1.5, 0.5))
    assert seen[0][0] > 0.9 and seen[1][0] > 0.9, seen      # the `root` quad: always there
    assert seen[1][1] > 0.9, seen                          # the `tip` quad, straight
    assert seen[0][1] < 0.1, seen                          # folded away at frame 0


def test_points_and_basis_curves_are_posed_like_meshes(stage, delegate):
    """UsdSkel skins any point-based gprim: Points and BasisCurves bound to the rig move as the
    mesh's vertices do (a ribbon keeps its authored normals, and says so)."""
    _scene(stage)
    skel = stage.GetPrimAtPath("/World/Char/Skel")
    pts = UsdGeom.Points.Define(stage, "/World/Char/Drops")
    curves = UsdGeom.BasisCurves.Define(stage, "/World/Char/Rope")
    curves.CreateTypeAttr("linear")
    curves.CreateCurveVertexCountsAttr([6])
    curves.CreateNormalsAttr([(0, 0, 1)] * 6)
    for g in (pts, curves):
        g.CreatePointsAttr(STRIP)
        binding = UsdSkel.BindingAPI.Apply(g.GetPrim())
        binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
        binding.CreateJointIndicesPrimvar(False, 1).Set([0, 0, 1, 0, 0, 1])
        binding.CreateJointWeightsPrimvar(False, 1).Set([1.0] * 6)
        binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    _, problems = load(stage, delegate, frame=0.5)
    assert [(p.prim, p.attribute) for p in problems] == [("/World/Char/Rope", "normals")], problems
    for path in ("/World/Char/Drops", "/World/Char/Rope"):
        assert np.allclose(floats(delegate.value(path, "points")), _posed(45), atol=1e-5), path
        assert np.allclose(_translation(delegate.value(path, "transform")), SKEL_WORLD)
        assert not any(n.startswith("skel:") for n in delegate.primvars.get(path, {}))
    assert "normals" in delegate.primvars["/World/Char/Rope"]
