"""Skinned meshes (UsdSkel), posed as UsdSkelImaging poses them, with plain usd-core.

A mesh bound to a Skeleton under a SkelRoot is deformed by the skeleton's animation: its blend
shapes first (weights from the SkelAnimation), then skinning by the joints' skinning transforms
(the binding's skinningMethod: linear blend or dual quaternion). The skinned points are in the
Skeleton's space, so the mesh is placed by the Skeleton's local-to-world transform instead of
its own. A mesh with blend shapes and no joint influences stays in its own space.

`Skinning` is built once per sync: it populates one `UsdSkel.Cache` per SkelRoot on first use
and computes each skeleton's skinning transforms once per time. Bad input (malformed joint
influences, a skeleton whose pose cannot be computed, blend shapes that do not fit the points)
is reported through `problem(prim, attribute, message)`; that mesh then renders unskinned, with
its authored points and its own transform.
"""
from tide import env

env.prepare()

import math  # noqa: E402

import numpy as np  # noqa: E402
from pxr import Gf, Sdf, Usd, UsdGeom, UsdSkel, Vt  # noqa: E402

# Pose samples over the shutter: where a joint turns by more than MAX_TURN radians between two,
# more are taken between them, up to MAX_STEPS steps (see SkinnedMesh.turning_offsets).
MAX_TURN = 0.1
MAX_STEPS = 16
JOINT_INDICES = "primvars:skel:jointIndices"
JOINT_WEIGHTS = "primvars:skel:jointWeights"
_PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
_UNSKINNED = "the mesh renders unskinned"


def skel_root(stage, path):
    """The outermost SkelRoot at or above `path` (which may name a removed prim), or None.

    The outermost one, so that a skeleton bound above a nested SkelRoot is still seen."""
    found = None
    path = path.GetPrimPath() if path.IsPropertyPath() else path
    while path != Sdf.Path.absoluteRootPath and not path.isEmpty:
        prim = stage.GetPrimAtPath(path)
        if prim and prim.IsA(UsdSkel.Root):
            found = prim
        path = path.GetParentPath()
    return found


def is_source(prim):
    """Whether `prim` is one that skinned meshes elsewhere read: a Skeleton, a SkelAnimation or
    a BlendShape."""
    return bool(prim) and (prim.IsA(UsdSkel.Skeleton) or prim.IsA(UsdSkel.BlendShape)
                           or UsdSkel.IsSkelAnimationPrim(prim))


def _normal_matrix(m):
    """The inverse transpose of a 4 x 4 transform's 3 x 3 part: how it turns normals."""
    return Gf.Matrix3d(*[m[i][j] for i in range(3) for j in range(3)]).GetInverse().GetTranspose()


def _t(time):
    return time.GetValue() if isinstance(time, Usd.TimeCode) else float(time)


class SkinnedMesh:
    """One mesh's skinning: the prims it reads and its posed points at given times."""

    def __init__(self, owner, prim, skeleton, skel_query, query):
        self._owner = owner
        self._problem = owner.problem
        self.prim = prim
        self.skeleton = skeleton          # the Skeleton prim
        self._skel_query = skel_query
        self._query = query
        self._points = UsdGeom.PointBased(prim).GetPointsAttr()
        self._joints = query.HasJointInfluences()
        self._shapes = query.HasBlendShapes()
        # the prim whose local-to-world transform places the deformed points: skinned points
        # are in the skeleton's space; blend shapes alone leave the mesh in its own
        self.space = skeleton if self._joints else prim
        anim = skel_query.GetAnimQuery()
        self._anim = anim if anim else None
        self.sources = [skeleton.GetPath()]
        if self._anim is not None:
            self.sources.append(self._anim.GetPrim().GetPath())
        if self._shapes:
            self.sources += list(query.GetBlendShapeTargetsRel().GetForwardedTargets())
            self._shape_query = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
            self._shape_indices = self._shape_query.ComputeBlendShapePointIndices()
            self._shape_offsets = self._shape_query.ComputeSubShapePointOffsets()

    def time_samples(self, interval):
        """Times within `interval` (a Gf.Interval) at which the pose may change: joint
        animation, blend-shape weights, joint influences, geomBindTransform and points."""
        # from the binding's attributes one by one: the skinning query's own gathering reads
        # every one of them and fails on any the prim does not author (an optional
        # geomBindTransform, a blend-shape-only prim's joint influences)
        binding = UsdSkel.BindingAPI(self.prim)
        times = set(self._points.GetTimeSamplesInInterval(interval))
        for attr in (binding.GetJointIndicesPrimvar().GetAttr(), binding.GetJointWeightsPrimvar().GetAttr(),
                     binding.GetGeomBindTransformAttr(), binding.GetBlendShapesAttr()):
            if attr and attr.IsValid():
                times.update(attr.GetTimeSamplesInInterval(interval))
        if self._anim is not None:
            if self._joints:
                times.update(self._anim.GetJointTransformTimeSamplesInInterval(interval))
            if self._shapes:
                times.update(self._anim.GetBlendShapeWeightTimeSamplesInInterval(interval))
        return sorted(times)

    def turning_offsets(self, offsets, time_fn):
        """`offsets` (sorted shutter offsets; `time_fn` gives each one's time code) with more
        between two where a joint turns by over MAX_TURN radians from one to the next (at most
        MAX_STEPS steps each): a point skinned to a turning joint then moves along its arc
        rather than its chord (within r (1 - cos(MAX_TURN / 2)) of it at r from the joint) over
        the shutter. Joint rotations are interpolated as UsdSkel interpolates them, by the
        animation's own samples."""
        if not self._joints or len(offsets) < 2:
            return offsets
        frames = []
        for o in offsets:
            xf = self._owner.skinning_transforms(self.skeleton, self._skel_query, time_fn(o))
            if xf is None or len(xf) == 0:
                return offsets
            m = np.asarray(xf, dtype=np.float64).reshape(-1, 4, 4)[:, :3, :3]
            # each joint's axes (the rows: USD's matrices act on row vectors), made unit
            frames.append(m / np.maximum(np.linalg.norm(m, axis=2, keepdims=True), 1e-30))
        out = [offsets[0]]
        for (a, fa), (b, fb) in zip(zip(offsets, frames), zip(offsets[1:], frames[1:])):
            turn = float(np.arccos(np.clip(np.sum(fa * fb, axis=2), -1.0, 1.0)).max())
            steps = min(MAX_STEPS, max(1, math.ceil(turn / MAX_TURN)))
            out += [a + (b - a) * k / steps for k in range(1, steps)] + [b]
        return out

    def compute(self, times):
        """[(points Nx3 float32 in the space of `space`, its local-to-world Gf.Matrix4d)] at
        each time, or None when the pose cannot be computed (reported)."""
        out = []
        count = None
        space = UsdGeom.Xformable(self.space)
        for time in times:
            time = time if isinstance(time, Usd.TimeCode) else Usd.TimeCode(time)
            pts = self._points.Get(time)
            if pts is None:
                return None   # the mesh itself reports that it has no points
            if count is None:
                count = len(pts)
            elif len(pts) != count:
                self._problem(self.prim.GetPath(), "points", "%d points at time %g, %d at "
                              "time %g; the topology must not change, so %s"
                              % (len(pts), _t(time), count, _t(times[0]), _UNSKINNED))
                return None
            pts = Vt.Vec3fArray(pts)
            if self._shapes and not self._blend(pts, time):
                return None
            if self._joints and not self._skin(pts, time):
                return None
            arr = np.array(pts, dtype=np.float32).reshape(-1, 3)
            if not np.all(np.isfinite(arr)):
                self._problem(self.prim.GetPath(), "points", "NaN or infinite skinned points at "
                              "time %g; %s" % (_t(time), _UNSKINNED))
                return None
            out.append((arr, space.ComputeLocalToWorldTransform(time)))
        return out

    # -- blend shapes ---------------------------------------------------------------------
    def _sub_weights(self, time):
        """The blend shapes' sub-shape weights at `time` (UsdSkel's), () when every shape is at
        rest, or None when the weights do not fit the targets (reported)."""
        if self._anim is None:
            return ()     # no weights: every shape at rest
        weights = self._anim.ComputeBlendShapeWeights(time)
        if weights is None or not len(weights):
            return ()
        weights = self._query.GetBlendShapeMapper().Remap(weights)
        q = self._shape_query
        if q.GetNumBlendShapes() != len(weights):
            self._problem(self.prim.GetPath(), "skel:blendShapeTargets", "%d usable targets for "
                          "%d skel:blendShapes; %s" % (q.GetNumBlendShapes(), len(weights),
                                                       _UNSKINNED))
            return None
        return q.ComputeSubShapeWeights(weights)

    def _blend(self, pts, time):
        sub = self._sub_weights(time)
        if not sub:
            return sub is not None
        q = self._shape_query
        sub_weights, shape_idx, sub_idx = sub
        n = len(pts)
        # checked here so that a bad shape is reported by name rather than by UsdSkel's warning
        for b, s in zip(shape_idx, sub_idx):
            shape = q.GetBlendShape(b).GetPrim().GetPath()
            indices = np.asarray(self._shape_indices[b], dtype=np.int64)
            want = indices.size if indices.size else n
            if len(self._shape_offsets[s]) != want:
                self._problem(shape, "offsets", "%d offsets for %d %s; %s (%s)"
                              % (len(self._shape_offsets[s]), want,
                                 "pointIndices" if indices.size else "points", _UNSKINNED,
                                 self.prim.GetPath()))
                return False
            if indices.size and (indices.min() < 0 or indices.max() >= n):
                self._problem(shape, "pointIndices", "point index out of range (0..%d); %s (%s)"
                              % (n - 1, _UNSKINNED, self.prim.GetPath()))
                return False
        if not q.ComputeDeformedPoints(sub_weights, shape_idx, sub_idx, self._shape_indices,
                                       self._shape_offsets, pts):
            self._problem(self.prim.GetPath(), "skel:blendShapes", "the blend shapes cannot be "
                          "applied at time %g; %s" % (_t(time), _UNSKINNED))
            return False
        return True

    # -- normals --------------------------------------------------------------------------
    def compute_normals(self, normals, interpolation, face_vertex_indices, n_points, time):
        """Authored normals (N x 3 float32, indices applied) deformed as the points are at
        `time`: the blend shapes' normalOffsets, then the joints by the binding's
        skinningMethod (UsdSkel's normal skinning: the inverse transposes of the skinning
        transforms' 3 x 3 parts). `vertex` and `varying` normals are per point, `faceVarying`
        ones per face corner (`face_vertex_indices` names each corner's point), which the
        joints turn but normalOffsets do not (UsdSkel's schema offsets points' normals only,
        and its baking leaves face-varying ones to the joints). None where they
        cannot be: `uniform` or `constant` normals, or normalOffsets that do not fit (reported);
        the caller then lets the core compute normals from the posed points."""
        path = self.prim.GetPath()
        per_corner = interpolation == "faceVarying"
        if interpolation not in ("vertex", "varying", "faceVarying"):
            self._problem(path, "normals", "%s normals of a skinned mesh cannot follow its "
                          "points; normals are computed from the posed points" % interpolation)
            return None
        corner_points = np.asarray(face_vertex_indices, dtype=np.int64)
        if len(normals) != (len(corner_points) if per_corner else n_points):
            return None   # the mesh conversion reports normals of the wrong length
        out = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(normals, dtype=np.float32))
        if self._shapes and not per_corner:
            delta = self._normal_offsets(n_points, time)
            if delta is None:
                return None
            if delta is not False:
                out = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(
                    np.asarray(out) + (delta[corner_points] if per_corner else delta),
                    dtype=np.float32))
        if self._joints:
            xforms = self._owner.skinning_transforms(self.skeleton, self._skel_query, time)
            if xforms is None:
                return None
            q = self._query
            mapper = q.GetJointMapper()
            if mapper and not mapper.IsIdentity():
                xforms = mapper.RemapTransforms(xforms)
            joints = Vt.Matrix3dArray([_normal_matrix(m) for m in xforms])
            per = q.GetNumInfluencesPerComponent()
            idx, weights = q.ComputeVaryingJointInfluences(n_points, time)
            if per_corner:
                # each face corner takes its point's influences
                per_point = lambda a, kind: np.asarray(a, dtype=kind).reshape(-1, per)
                idx = Vt.IntArray.FromNumpy(per_point(idx, np.int32)[corner_points].ravel())
                weights = Vt.FloatArray.FromNumpy(
                    per_point(weights, np.float32)[corner_points].ravel())
            bind = _normal_matrix(q.GetGeomBindTransform(time))
            if not UsdSkel.SkinNormals(q.GetSkinningMethod(), bind, joints, idx, weights, per,
                                       out):
                return None
        arr = np.asarray(out, dtype=np.float32).reshape(-1, 3)
        return arr if np.all(np.isfinite(arr)) else None

    def _normal_offsets(self, n_points, time):
        """The blend shapes' normal offsets at `time`, summed per point (N x 3); False when no
        target authors normalOffsets (normals are then as authored), None when one does not fit
        (reported)."""
        q = self._shape_query
        if not any(q.GetBlendShape(b).GetNormalOffsetsAttr().HasAuthoredValue()
                   for b in range(q.GetNumBlendShapes())):
            return False
        sub = self._sub_weights(time)
        if sub is None:
            return None
        delta = Vt.Vec3fArray(n_points)
        if not sub:
            return np.zeros((n_points, 3), dtype=np.float32)
        sub_weights, shape_idx, sub_idx = sub
        offsets = []
        for i, points in enumerate(self._shape_offsets):
            inbetween = q.GetInbetween(i)
            shape = q.GetBlendShape(q.GetBlendShapeIndex(i))
            normal = (inbetween.GetNormalOffsets() if inbetween and inbetween.IsDefined()
                      else shape.GetNormalOffsetsAttr().Get()) if len(points) else None
            if normal is None or not len(normal):
                normal = Vt.Vec3fArray(len(points))
            elif len(normal) != len(points):
                self._problem(shape.GetPrim().GetPath(), "normalOffsets", "%d normalOffsets for "
                              "%d offsets; normals are computed from the posed points (%s)"
                              % (len(normal), len(points), self.prim.GetPath()))
                return None
            offsets.append(normal)
        if not q.ComputeDeformedPoints(sub_weights, shape_idx, sub_idx, self._shape_indices,
                                       offsets, delta):
            return None
        return np.asarray(delta, dtype=np.float32).reshape(-1, 3)

    # -- joints ---------------------------------------------------------------------------
    def _skin(self, pts, time):
        xforms = self._owner.skinning_transforms(self.skeleton, self._skel_query, time)
        if xforms is None:
            return False
        if not self._influences_ok(len(pts), time):
            return False
        # Constant (rigid) influences are expanded to every point here, which is the same as
        # moving the mesh by ComputeSkinnedTransform's matrix.
        if not self._query.ComputeSkinnedPoints(xforms, pts, time):
            self._problem(self.prim.GetPath(), JOINT_INDICES, "the points cannot be skinned at "
                          "time %g; %s" % (_t(time), _UNSKINNED))
            return False
        return True

    def _influences_ok(self, n, time):
        """Checks the joint indices and weights as UsdSkel would, to report what is wrong by
        attribute (UsdSkel itself only warns and leaves the points as they are)."""
        path = self.prim.GetPath()
        q = self._query
        idx = q.GetJointIndicesPrimvar().ComputeFlattened(time)
        weights = q.GetJointWeightsPrimvar().ComputeFlattened(time)
        per = q.GetNumInfluencesPerComponent()
        rigid = q.IsRigidlyDeformed()
        want = per if rigid else per * n
        how = ("%d (elementSize, constant interpolation)" % per if rigid
               else "%d (%d points x elementSize %d)" % (want, n, per))
        for name, values in ((JOINT_INDICES, idx), (JOINT_WEIGHTS, weights)):
            got = 0 if values is None else len(values)
            if got != want:
                self._problem(path, name, "%d values where %s are needed; %s"
                              % (got, how, _UNSKINNED))
                return False
        order = q.GetJointOrder()
        joints = len(order) if order is not None else len(self._skel_query.GetJointOrder())
        idx = np.asarray(idx, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= joints):
            bad = int(idx.max()) if idx.max() >= joints else int(idx.min())
            self._problem(path, JOINT_INDICES, "joint index %d out of range: %s has %d joints; %s"
                          % (bad, "skel:joints" if order is not None else "the skeleton",
                             joints, _UNSKINNED))
            return False
        if not np.all(np.isfinite(np.asarray(weights, dtype=np.float64))):
            self._problem(path, JOINT_WEIGHTS, "NaN or infinite weights; %s" % _UNSKINNED)
            return False
        return True


class Skinning:
    """The skinned meshes of a stage: built once per sync (edits need a new one)."""

    def __init__(self, stage, problem):
        self.stage = stage
        self.problem = problem
        self._cache = UsdSkel.Cache()
        self._roots = {}        # SkelRoot path -> {mesh path: (skeleton prim, skel query, query)}
        self._xforms = {}       # (skeleton path, time) -> skinning transforms | None
        self._outer = {}        # prim path -> outermost SkelRoot at or above it | None

    def target(self, prim):
        """The skinning of mesh `prim`, or None when no skeleton deforms it (also when its
        joint influences are unusable: reported, the mesh renders unskinned)."""
        path = prim.GetPath()
        root = self._outer_root(path.GetParentPath())
        if root is None and prim.IsA(UsdSkel.Root):
            root = prim
        if root is None:
            if self._has_influences(prim):
                self.problem(path, "skel:skeleton", "joint influences outside any SkelRoot; "
                             "%s" % _UNSKINNED)
            return None
        bound = self._roots.get(root.GetPath())
        if bound is None:
            bound = self._roots[root.GetPath()] = self._populate(root)
        found = bound.get(path)
        if found is None:
            if self._has_influences(prim):
                self.problem(path, "skel:skeleton", "joint influences but no Skeleton bound "
                             "(skel:skeleton); %s" % _UNSKINNED)
            return None
        skeleton, skel_query, query = found
        if not skel_query:
            self.problem(skeleton.GetPath(), "joints", "the Skeleton cannot be used (see its "
                         "joints and bindTransforms); %s (%s)" % (_UNSKINNED, path))
            return None
        if not query.HasJointInfluences():
            if self._has_influences(prim):
                self._bad_influences(query)
                return None
            if not query.HasBlendShapes():
                return None
        self._check_joint_names(prim, skeleton)
        return SkinnedMesh(self, prim, skeleton, skel_query, query)

    def _check_joint_names(self, prim, skeleton):
        """Names the joints a prim's (or its ancestors') `skel:joints` lists that its Skeleton
        does not have (UsdSkel leaves their influences out, with no more than a warning)."""
        p = prim
        while p and not p.IsPseudoRoot():
            attr = UsdSkel.BindingAPI(p).GetJointsAttr()
            if attr and attr.HasAuthoredValue():
                have = set(UsdSkel.Skeleton(skeleton).GetJointsAttr().Get() or [])
                unknown = [str(j) for j in (attr.Get() or []) if j not in have]
                if unknown:
                    self.problem(p.GetPath(), "skel:joints", "names joints the Skeleton %s does "
                                 "not have (%s); their influences are left out"
                                 % (skeleton.GetPath(), ", ".join(unknown[:3])))
                return
            p = p.GetParent()

    def compute(self, prim, times):
        """[(points Nx3 float32, local-to-world Gf.Matrix4d of the space they are in)] of mesh
        `prim` at each of `times` (for a skinned mesh: skeleton space and the Skeleton's
        transform), or None when it is not skinned or cannot be (reported)."""
        target = self.target(prim)
        return None if target is None else target.compute(times)

    def skinning_transforms(self, skeleton, skel_query, time):
        """The skeleton's skinning transforms at `time`, once per skeleton and time; None when
        the pose cannot be computed (reported on the Skeleton)."""
        key = (skeleton.GetPath(), _t(time))
        if key in self._xforms:
            return self._xforms[key]
        path = skeleton.GetPath()
        skel = UsdSkel.Skeleton(skeleton)
        joints = len(skel.GetJointsAttr().Get() or [])
        bind = skel.GetBindTransformsAttr().Get() or []
        xforms = None
        if len(bind) != joints:
            self.problem(path, "bindTransforms", "%d bindTransforms for %d joints; the "
                         "skeleton's meshes render unskinned" % (len(bind), joints))
        else:
            self._check_animation(skel_query, time)
            xforms = skel_query.ComputeSkinningTransforms(time)
            if len(xforms) != joints:
                rest = len(skel.GetRestTransformsAttr().Get() or [])
                self.problem(path, "restTransforms", "the pose cannot be computed at time %g: "
                             "%d restTransforms for %d joints (needed for every joint the "
                             "animation does not drive); the skeleton's meshes render unskinned"
                             % (_t(time), rest, joints))
                xforms = None
            elif joints and not np.all(np.isfinite(np.asarray(xforms, dtype=np.float64))):
                self.problem(path, "skel:animationSource", "NaN or infinite joint transforms at "
                             "time %g; the skeleton's meshes render unskinned" % _t(time))
                xforms = None
        self._xforms[key] = xforms
        return xforms

    # -- internals ------------------------------------------------------------------------
    def _check_animation(self, skel_query, time):
        """Names what keeps a SkelAnimation from posing its joints at `time` (UsdSkel then
        falls back to the rest pose with no more than a warning): translations, rotations or
        scales of another count than its joints, or some of them without a value."""
        anim_query = skel_query.GetAnimQuery()
        prim = anim_query.GetPrim() if anim_query else None
        if not prim or not prim.IsA(UsdSkel.Animation):
            return
        anim = UsdSkel.Animation(prim)
        joints = len(anim.GetJointsAttr().Get() or [])
        attrs = (anim.GetTranslationsAttr(), anim.GetRotationsAttr(), anim.GetScalesAttr())
        values = [a.Get(time) if a and a.HasValue() else None for a in attrs]
        if all(v is None for v in values):
            return
        for attr, v in zip(attrs, values):
            if v is None or len(v) != joints:
                self.problem(prim.GetPath(), attr.GetName(), "%s for %d joints; the animation "
                             "does not pose them (the rest pose is used)"
                             % ("no value" if v is None else "%d values" % len(v), joints))
                return

    def _outer_root(self, path):
        """skel_root for the prims of a sync, remembered per path (siblings share it)."""
        if path == Sdf.Path.absoluteRootPath or path.isEmpty:
            return None
        if path not in self._outer:
            found = self._outer_root(path.GetParentPath())
            if found is None:
                prim = self.stage.GetPrimAtPath(path)
                if prim and prim.IsA(UsdSkel.Root):
                    found = prim
            self._outer[path] = found
        return self._outer[path]

    def _populate(self, root):
        out = {}
        skel_root_ = UsdSkel.Root(root)
        if not self._cache.Populate(skel_root_, _PREDICATE):
            return out
        for binding in self._cache.ComputeSkelBindings(skel_root_, _PREDICATE):
            skeleton = binding.GetSkeleton()
            skel_query = self._cache.GetSkelQuery(skeleton)
            for query in binding.GetSkinningTargets():
                out[query.GetPrim().GetPath()] = (skeleton.GetPrim(), skel_query, query)
        return out

    @staticmethod
    def _has_influences(prim):
        """Whether the mesh authors joint influences (so it is meant to be skinned)."""
        for name in (JOINT_INDICES, JOINT_WEIGHTS):
            attr = prim.GetAttribute(name)
            if attr and attr.HasAuthoredValue():
                return True
        return False

    def _bad_influences(self, query):
        """Says why UsdSkel refused a mesh's joint influences."""
        prim = query.GetPrim()
        path = prim.GetPath()
        indices = UsdGeom.Primvar(prim.GetAttribute(JOINT_INDICES))
        weights = UsdGeom.Primvar(prim.GetAttribute(JOINT_WEIGHTS))
        for name, pv in ((JOINT_INDICES, indices), (JOINT_WEIGHTS, weights)):
            if not (pv and pv.GetAttr().HasAuthoredValue()):
                self.problem(path, name, "missing, while %s is authored; %s"
                             % (JOINT_WEIGHTS if name == JOINT_INDICES else JOINT_INDICES,
                                _UNSKINNED))
                return
        if indices.GetElementSize() != weights.GetElementSize():
            self.problem(path, JOINT_WEIGHTS, "elementSize %d differs from %s's %d; %s"
                         % (weights.GetElementSize(), JOINT_INDICES, indices.GetElementSize(),
                            _UNSKINNED))
            return
        if indices.GetInterpolation() != weights.GetInterpolation():
            self.problem(path, JOINT_WEIGHTS, "interpolation '%s' differs from %s's '%s'; %s"
                         % (weights.GetInterpolation(), JOINT_INDICES,
                            indices.GetInterpolation(), _UNSKINNED))
            return
        interp = str(indices.GetInterpolation())
        if interp not in ("constant", "vertex"):
            self.problem(path, JOINT_INDICES, "interpolation '%s' (joint influences are "
                         "'constant' or 'vertex'); %s" % (interp, _UNSKINNED))
            return
        self.problem(path, JOINT_INDICES, "joint influences UsdSkel cannot use (elementSize %d)"
                     "; %s" % (indices.GetElementSize(), _UNSKINNED))
