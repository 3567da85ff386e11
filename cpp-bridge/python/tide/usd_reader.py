"""The usd-core scene reader: walks a USD stage and drives Tide's RenderDelegate as Hydra would.

It does UsdImaging's job with plain usd-core: composition, native instancing and point
instancers (both with motion over the camera shutter), purposes, inherited visibility,
transforms with motion samples over the shutter, deforming points (time samples, velocities,
accelerations), skinned meshes (UsdSkel, in `skel`), material binding resolution (also of
materialBind GeomSubsets), light linking collections, render settings / products / vars and
camera selection. It then keeps the delegate in step with edits made through usd-core
(`Reader.update()`, driven by `Usd.Notice.ObjectsChanged`).

Every value sent to the delegate is remembered, so a later sync sends only what changed and
the delegate marks only those prims dirty. Problems in the stage (contract section 7) are
collected as `Problem(prim, attribute, message)`, each reported once; the rest renders.
"""
import contextlib
import hashlib
import math
import os
from collections import namedtuple

from tide import env

env.prepare()

import numpy as np  # noqa: E402
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdVol  # noqa: E402

from tide import nurbs, skel  # noqa: E402

env.register_shaders()


class Problem(namedtuple("Problem", "prim attribute message")):
    """Something wrong in the stage: which prim, which attribute, what is wrong."""

    def __str__(self):
        return "%s: %s: %s" % (self.prim, self.attribute, self.message)

    @classmethod
    def of_delegate(cls, prim, attribute, message):
        """A problem the delegate found. It names a material's node input as (material,
        "/node/path.input"): that is the node's prim and its input, as the reader names them
        (so that one fault found by both is reported once)."""
        if attribute.startswith("/"):
            dot = attribute.find(".", attribute.rfind("/"))
            if dot > 0:
                return cls(attribute[:dot], attribute[dot + 1:], message)
        return cls(prim, attribute, message)


# USD prim type -> delegate rprim type.
GPRIMS = {
    "Mesh": "mesh", "BasisCurves": "basisCurves", "NurbsCurves": "basisCurves",
    "HermiteCurves": "basisCurves", "TetMesh": "mesh", "NurbsPatch": "mesh",
    "Points": "points", "Sphere": "sphere",
    "Cube": "cube",
    "Cylinder": "cylinder", "Cylinder_1": "cylinder", "Cone": "cone", "Capsule": "capsule",
    "Capsule_1": "capsule", "Plane": "plane", "TideOcean": "tideOcean", "Volume": "volume",
}
LIGHTS = {
    "DistantLight": "distantLight", "DomeLight": "domeLight", "DomeLight_1": "domeLight",
    "SphereLight": "sphereLight", "RectLight": "rectLight", "DiskLight": "diskLight",
    "CylinderLight": "cylinderLight",
}
# Attributes sent per implicit gprim, with USD's fallbacks.
IMPLICIT_ATTRS = {
    "sphere": {"radius": 1.0},
    "cube": {"size": 2.0},
    "cylinder": {"radius": 1.0, "height": 2.0, "axis": "Z"},
    "cone": {"radius": 1.0, "height": 2.0, "axis": "Z"},
    "capsule": {"radius": 0.5, "height": 1.0, "axis": "Z"},
    "plane": {"width": 2.0, "length": 2.0, "axis": "Z"},
}
# The schemas with a radius per end (a tapered cylinder, a capsule of two spheres) send those.
IMPLICIT_ATTRS_BY_SCHEMA = {
    "Cylinder_1": {"radiusBottom": 1.0, "radiusTop": 1.0, "height": 2.0, "axis": "Z"},
    "Capsule_1": {"radiusBottom": 0.5, "radiusTop": 0.5, "height": 1.0, "axis": "Z"},
}
LIGHT_COMMON = {
    "inputs:intensity": 1.0, "inputs:exposure": 0.0, "inputs:color": (1.0, 1.0, 1.0),
    "inputs:normalize": False, "inputs:enableColorTemperature": False,
    "inputs:colorTemperature": 6500.0, "inputs:diffuse": 1.0, "inputs:specular": 1.0,
}
LIGHT_SPECIFIC = {
    "distantLight": {"inputs:angle": 0.53},
    "domeLight": {"inputs:texture:file": Sdf.AssetPath(""), "inputs:texture:format": "automatic"},
    "sphereLight": {"inputs:radius": 0.5, "treatAsPoint": False},
    "rectLight": {"inputs:width": 1.0, "inputs:height": 1.0,
                  "inputs:texture:file": Sdf.AssetPath("")},
    "diskLight": {"inputs:radius": 0.5},
    "cylinderLight": {"inputs:radius": 0.5, "inputs:length": 1.0, "treatAsLine": False},
}
# UsdRenderSettingsBase attributes (besides the camera) a product may override.
# widest and tallest image the core renders (tide_core::render::MAX_IMAGE_SIDE)
MAX_IMAGE_SIDE = 65536

BASE_ATTRS = ("resolution", "pixelAspectRatio", "aspectRatioConformPolicy", "dataWindowNDC",
              "disableMotionBlur", "disableDepthOfField")
# UsdLuxShapingAPI and UsdLuxShadowAPI: sent where the prim has them (the API applied, or
# authored).
LIGHT_API_ATTRS = (
    "inputs:shaping:cone:angle", "inputs:shaping:cone:softness", "inputs:shaping:focus",
    "inputs:shaping:focusTint", "inputs:shaping:ies:file", "inputs:shaping:ies:angleScale",
    "inputs:shaping:ies:normalize", "inputs:shadow:enable", "inputs:shadow:color",
    "inputs:shadow:distance", "inputs:shadow:falloff", "inputs:shadow:falloffGamma",
)
CAMERA_ATTRS = {
    "projection": "perspective", "focalLength": 50.0, "horizontalAperture": 20.955,
    "verticalAperture": 15.2908, "horizontalApertureOffset": 0.0,
    "verticalApertureOffset": 0.0, "clippingRange": (1.0, 1000000.0), "fStop": 0.0,
    "focusDistance": 0.0, "shutter:open": 0.0, "shutter:close": 0.0, "exposure": 0.0,
    "exposure:fStop": 1.0, "exposure:time": 1.0, "exposure:iso": 100.0,
    "exposure:responsivity": 1.0, "tide:camera:filter": "none",
}
SETTINGS_TIDE = {
    "tide:integrator": "caustics", "tide:samples": 64, "tide:maxDepth": 64,
    "tide:adaptive:threshold": 0.0, "tide:adaptive:minSamples": 0, "tide:seed": 0,
    "tide:time:budget": 0.0, "tide:pixelFilter": "box", "tide:pixelFilter:width": 0.0,
}
ALLOWED_TOKENS = {
    "tide:integrator": ("path", "caustics"),
    "tide:pixelFilter": ("gaussian", "box", "triangle"),
    "tide:camera:filter": ("none", "underwaterRed"),
    "projection": ("perspective", "orthographic"),
    "orientation": ("rightHanded", "leftHanded"),
    "subdivisionScheme": ("catmullClark", "loop", "bilinear", "none"),
    "axis": ("X", "Y", "Z"),
    "interpolateBoundary": ("edgeAndCorner", "edgeOnly", "none"),
    "triangleSubdivisionRule": ("catmullClark", "smooth"),
    "light:materialSyncMode": ("materialGlowTintsLight", "independent", "noMaterialResponse"),
    "type": ("linear", "cubic"),
    "basis": ("bezier", "bspline", "catmullRom", "hermite"),
    "wrap": ("nonperiodic", "periodic", "pinned"),
    "tide:caustics:transparency": ("off", "afterDiffuse", "volume", "all"),
    "visibility": ("inherited", "invisible"),
    "purpose": ("default", "render", "proxy", "guide"),
}
# UsdRenderSettings.materialBindingPurposes' tokens ("" the all-purpose binding)
BINDING_PURPOSES = ("full", "preview", "")
# Tide's roles whose absence means "not tagged" (the one-click caustics default applies),
# unlike their schema's fallback
UNTAGGED_UNLESS_AUTHORED = ("tide:caustics:caster", "tide:caustics:emitter")
AOVS = {
    "color": "float4", "depth": "float", "normal": "float3",
    "albedo": "float3", "primId": "float", "instanceId": "float", "elementId": "float", "tide:diffuse": "float3",
    "tide:specular": "float3", "tide:transmission": "float3",
    "tide:volume": "float3", "tide:emission": "float3",
    "tide:caustics": "float3", "tide:guiding": "float3",
}
SHADER_IDS = {
    "UsdPreviewSurface", "UsdUVTexture", "UsdTransform2d", "UsdPrimvarReader_float",
    "UsdPrimvarReader_float2", "UsdPrimvarReader_float3", "UsdPrimvarReader_float4",
    "UsdPrimvarReader_int", "UsdPrimvarReader_string", "UsdPrimvarReader_normal",
    "UsdPrimvarReader_point", "UsdPrimvarReader_vector", "UsdPrimvarReader_matrix",
    "TideWater", "TideMedium",
}


def _set_instance_primvar(st, name, rows, tsize):
    """Sends `rows` (one per instance) as primvar `name` of interpolation `instance`, unless
    the gprim has a varying primvar of that name, which wins (a constant one is replaced)."""
    if st.primvars.get(name, ("constant",))[0] == "constant":
        st.primvars[name] = ("instance", np.ascontiguousarray(rows, dtype=np.float32).tobytes(),
                             tsize, None)


def _skinnable(prim, st):
    """Gprims a skeleton poses: meshes, points and basis curves (whose points are sent as
    authored; NURBS and Hermite curves are evaluated into others)."""
    return st.type in ("mesh", "points") or (st.type == "basisCurves" and prim.IsA(UsdGeom.BasisCurves))


def _link_collections(light, st):
    """A light's (or a mesh light's) light- and shadow-link collections, where authored. A
    collection whose members only USD's own query can tell (a path expression, or includes /
    excludes naming other collections) is kept on `st.queries` as (name, query): the reader
    sends it as the list of its members once it knows every prim (_resolve_link_queries)."""
    st.queries = []
    for which, coll in (("lightLink", light.GetLightLinkCollectionAPI()),
                        ("shadowLink", light.GetShadowLinkCollectionAPI())):
        if coll.IsInExpressionMode() or any(
                t.IsPropertyPath() for rel in (coll.GetIncludesRel(), coll.GetExcludesRel())
                for t in rel.GetTargets()):
            st.queries.append((which, coll.ComputeMembershipQuery()))
            continue
        inc = coll.GetIncludesRel().GetTargets()
        exc = coll.GetExcludesRel().GetTargets()
        root_attr = coll.GetIncludeRootAttr()
        include_root = root_attr.Get() if root_attr else None
        if inc or exc or (include_root is not None and root_attr.HasAuthoredValue()):
            base = "collection:%s:" % which
            st.set(base + "includes", ("paths", tuple(str(p) for p in inc)))
            st.set(base + "excludes", ("paths", tuple(str(p) for p in exc)))
            st.set(base + "includeRoot", ("bool", True if include_root is None
                                          else bool(include_root)))
            rule = coll.GetExpansionRuleAttr().Get()
            st.set(base + "expansionRule", ("token", str(rule or "expandPrims")))


def _known_shader(sid):
    """USD's and Tide's shaders; MaterialX nodes (`ND_...`) are judged by the delegate, which
    names each one it cannot read where it is used."""
    return sid in SHADER_IDS or sid.startswith("ND_")


def _render_context(output):
    """The render context a material's terminal is taken from: Tide's own, else MaterialX's,
    else the universal one."""
    for context in ("tide", "mtlx"):
        out = output(context)
        if out and out.HasConnectedSource():
            return context
    return ""


IDENTITY = tuple(float(x) for x in (1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1))
SETTINGS_FALLBACK_PATH = "/Render/__TideSettings"
# the camera a stage without one is seen through (Reader._default_camera)
DEFAULT_CAMERA_PATH = "/Render/__TideDefaultCamera"
BUFFER_ROOT = "/Render/__TideBuffers"

# vars: [(sourceName, buffer path)]; types: {sourceName: the RenderVar's authored dataType}
Product = namedtuple("Product", "path name vars types")
# Options attributes that override a render setting for every product alike.
OPTION_KEYS = {"spp": "tide:samples", "seed": "tide:seed", "integrator": "tide:integrator",
               "time_budget": "tide:time:budget", "max_depth": "tide:maxDepth",
               "pixel_filter": "tide:pixelFilter", "adaptive_threshold": "tide:adaptive:threshold"}


class Options:
    """What the command line (or a caller) overrides: settings prim, camera, frame, spp, ..."""

    def __init__(self, settings=None, camera=None, frame=None, spp=None, width=None,
                 seed=None, threads=None, output=None, integrator=None, time_budget=None,
                 max_depth=None, pixel_filter=None, pixel_filter_width=None,
                 adaptive_threshold=None, single_image=False, refine_level=0, files_only=False):
        self.settings = settings
        self.camera = camera
        self.frame = frame
        self.spp = spp
        self.width = width
        self.seed = seed
        self.threads = threads
        self.output = output
        self.integrator = integrator
        self.time_budget = time_budget
        self.max_depth = max_depth
        self.pixel_filter = pixel_filter
        self.pixel_filter_width = pixel_filter_width
        self.adaptive_threshold = adaptive_threshold
        # True: one image at the first product's settings carries every product's vars (as
        # `tide render -o` writes); False: products whose settings differ are rendered apart
        self.single_image = single_image
        # subdivision levels of meshes that author no tide:subdivision:level (usdrecord's and
        # usdview's complexity: Hydra's display style refineLevel)
        self.refine_level = refine_level
        # True: the render buffers of AOVs other than colour are not filled while rendering
        # (`tide:publish` false): their AOVs go to files, written from the film, and nothing
        # reads those buffers (a command-line render reads colour only, for its preview)
        self.files_only = files_only


# ---------------------------------------------------------------------------------------------
# Value conversion: USD values -> tagged, comparable values of the delegate protocol.
# ("bool"|"int"|"float"|"token"|"string"|"asset"|"path", v), ("paths", tuple),
# ("floats"|"doubles", tuple_size, bytes), ("ints", bytes), ("matrix", 16-tuple)

def _matrix(m):
    return ("matrix", tuple(float(m[i][j]) for i in range(4) for j in range(4)))


def _kind_ok(value, fallback):
    """Whether a USD value is of the kind of `fallback`, the value the reader expects: a bool
    for a bool, a whole number for an int, a number for a float, text for a token or string,
    an asset path for an asset, a sequence as long, of the same kinds, for a vector (a list: of
    any length)."""
    if isinstance(fallback, bool):
        return isinstance(value, bool)
    if isinstance(fallback, int):
        return (isinstance(value, int) and not isinstance(value, bool)) or \
            (isinstance(value, float) and value.is_integer())
    if isinstance(fallback, float):
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if isinstance(fallback, str):
        return isinstance(value, str)
    if isinstance(fallback, Sdf.AssetPath):
        return isinstance(value, Sdf.AssetPath)
    if hasattr(fallback, "__len__"):
        if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
            return False
        if not isinstance(fallback, list) and len(value) != len(fallback):
            return False
        return len(fallback) == 0 or all(_kind_ok(v, fallback[0]) for v in value)
    return True


def _kind_name(fallback):
    if isinstance(fallback, bool):
        return "a bool"
    if isinstance(fallback, int):
        return "a whole number"
    if isinstance(fallback, float):
        return "a number"
    if isinstance(fallback, str):
        return "a token"
    if isinstance(fallback, Sdf.AssetPath):
        return "an asset path"
    if isinstance(fallback, list):
        return "a list"
    return "%d numbers" % len(fallback)


def _times_matrix(ms, w):
    """Each of the matrices `ms` (n x 4 x 4, USD's row-vector convention) times `w`, as
    Gf.Matrix4d's product computes it (each element's four products summed in order; times the
    identity, each element is its own: `ms` itself is returned)."""
    if np.array_equal(w, np.eye(4)):
        return ms
    rows = ms.reshape(-1, 4)
    out = rows[:, 0:1] * w[0]
    term = np.empty_like(out)
    for k in range(1, 4):
        np.multiply(rows[:, k:k + 1], w[k], out=term)
        out += term
    return out.reshape(-1, 4, 4)


def _turns(w, dt):
    """The rotations (n x 3 x 3, USD's row-vector convention, as Gf.Rotation's matrix) by
    |w| dt degrees about each axis w (n x 3, degrees per second); the identity where w is zero."""
    speed = np.linalg.norm(w, axis=1)
    k = np.divide(w, speed[:, None], out=np.zeros_like(w), where=speed[:, None] > 0)
    a = np.radians(speed * dt)
    c, s = np.cos(a)[:, None, None], np.sin(a)[:, None, None]
    # Rodrigues' formula transposed (rows rotate): I cos a - sin a [k]x + (1 - cos a) k k^T
    cross = np.zeros((len(w), 3, 3))
    cross[:, 0, 1], cross[:, 0, 2] = -k[:, 2], k[:, 1]
    cross[:, 1, 0], cross[:, 1, 2] = k[:, 2], -k[:, 0]
    cross[:, 2, 0], cross[:, 2, 1] = -k[:, 1], k[:, 0]
    return np.eye(3) * c - s * cross + (1 - c) * k[:, :, None] * k[:, None, :]


def _floats(data, tuple_size):
    arr = np.ascontiguousarray(np.asarray(data, dtype=np.float32).reshape(-1))
    return ("floats", int(tuple_size), arr.tobytes())


def _ints(data):
    return ("ints", np.ascontiguousarray(np.asarray(data, dtype=np.int32).reshape(-1)).tobytes())


def _outside_primvar_names(prim, root):
    """The constant primvars gprim `prim` (an instance proxy under instance prim `root`)
    inherits from `root` or above: the ones its instances may each hold apart."""
    names = []
    for pv in UsdGeom.PrimvarsAPI(prim).FindPrimvarsWithInheritance():
        owner = pv.GetAttr().GetPrim().GetPath()
        if pv.GetInterpolation() == UsdGeom.Tokens.constant and \
                (owner == root or not owner.HasPrefix(root)):
            names.append(str(pv.GetPrimvarName()))
    return tuple(sorted(names))


def _piecewise_gradient(g, axis, cuts):
    """np.gradient of grid `g` along `axis`, each piece between cuts (a cut r: rows r and r + 1
    lie on either side of a break) on its own, so that no difference crosses a break."""
    edges = [0] + [r + 1 for r in cuts] + [g.shape[axis]]
    parts = []
    for a, b in zip(edges[:-1], edges[1:]):
        piece = np.take(g, range(a, b), axis=axis)
        if piece.shape[axis] < 2:
            parts.append(np.zeros_like(piece))
        else:
            parts.append(np.gradient(piece, axis=axis, edge_order=2 if piece.shape[axis] > 2 else 1))
    return np.concatenate(parts, axis=axis)


def _collapsed_edge_normals(n, scale):
    """Unit normals of a patch's grid (sv x su x 3 cross products of its derivatives); where
    a grid row or column collapses to a point (a sphere's pole), where the cross product
    vanishes, the mean of the next row's (or column's) normals: the surface's normal there."""
    length = np.linalg.norm(n, axis=2)
    bad = length <= 1e-9 * max(scale, 1e-30) ** 2
    unit = n / np.maximum(length, 1e-300)[..., None]
    if bad.any():
        for axis in (0, 1):
            last = n.shape[axis] - 1
            for edge, nxt in ((0, 1), (last, last - 1)):
                if nxt < 0 or nxt > last:
                    continue
                here = np.take(bad, edge, axis=axis)
                if here.any() and not np.take(bad, nxt, axis=axis).all():
                    ring = np.take(unit, nxt, axis=axis)[~np.take(bad, nxt, axis=axis)]
                    mean = ring.sum(axis=0)
                    if np.linalg.norm(mean) > 1e-9:
                        idx = [slice(None)] * 2
                        idx[axis] = edge
                        sub = unit[tuple(idx)]
                        sub[here] = mean / np.linalg.norm(mean)
                        bad[tuple(idx)] = False
    return unit


def _mtime(path):
    """A file's modification time (ns), None if it cannot be read."""
    try:
        return os.stat(path).st_mtime_ns
    except OSError:
        return None


def _tuple_size(arr):
    a = np.asarray(arr)
    return 1 if a.ndim <= 1 else int(np.prod(a.shape[1:]))


def _is_quat_array(value):
    return hasattr(value, "__len__") and len(value) and isinstance(
        value[0], (Gf.Quatf, Gf.Quatd, Gf.Quath))


def _quat_rows(value):
    """Quaternions as (i, j, k, real) rows, as every quaternion is sent."""
    return [[q.GetImaginary()[0], q.GetImaginary()[1], q.GetImaginary()[2], q.GetReal()]
            for q in value]


def convert(value, type_name=None):
    """A USD value as a protocol value, or None when it has no protocol form."""
    if value is None:
        return None
    if isinstance(value, bool):
        return ("bool", value)
    if isinstance(value, int):
        return ("int", value)
    if isinstance(value, float):
        return ("float", value)
    if isinstance(value, str):
        if type_name is not None and type_name == Sdf.ValueTypeNames.String:
            return ("string", value)
        return ("token", value)
    if isinstance(value, Sdf.AssetPath):
        return ("asset", value.resolvedPath or "")
    if isinstance(value, (Gf.Matrix4d, Gf.Matrix4f)):
        return _matrix(value)
    if isinstance(value, (Gf.Quatf, Gf.Quatd, Gf.Quath)):
        im = value.GetImaginary()
        return _floats([im[0], im[1], im[2], value.GetReal()], 4)
    if isinstance(value, (Gf.Matrix3d, Gf.Matrix3f, Gf.Matrix2d, Gf.Matrix2f)):
        return _floats(np.asarray(value), np.asarray(value).size)
    if hasattr(value, "__len__") and not hasattr(value, "_isVtArray") and type(value).__module__.endswith("Gf"):
        return _floats(list(value), len(value))
    # Vt arrays
    if isinstance(value, Sdf.PathListOp) or isinstance(value, Sdf.Path):
        return ("path", str(value))
    try:
        seq = list(value) if len(value) and isinstance(value[0], str) else None
    except TypeError:
        return None
    if seq is not None:
        return ("paths", tuple(seq))
    if len(value) and isinstance(value[0], Sdf.AssetPath):
        return ("paths", tuple(v.resolvedPath for v in value))
    if _is_quat_array(value):
        return _floats(_quat_rows(value), 4)
    arr = np.asarray(value)
    if arr.dtype == object:
        return None
    if arr.dtype.kind in "iub" and (arr.ndim <= 1):
        return _ints(arr)
    if arr.dtype == np.float64 and arr.ndim == 3 and arr.shape[1:] == (4, 4):
        return ("doubles", 16, np.ascontiguousarray(arr.reshape(-1)).tobytes())
    return _floats(arr, _tuple_size(arr))


def _mistyped(prim, attr):
    """Why `attr` cannot be read as its schema declares it: authored with another value type
    (the attribute reports the schema's type; the strongest opinion keeps its own); None when it
    is fine or no schema declares it."""
    defn = prim.GetPrimDefinition()
    d = defn.GetAttributeDefinition(attr.GetName()) if defn else None
    if not d:
        return None
    stack = attr.GetPropertyStack(Usd.TimeCode.Default())
    authored = getattr(stack[0], "typeName", None) if stack else None
    if authored and d.GetTypeName().type != authored.type:
        return "authored as %s where its schema declares %s" % (authored, d.GetTypeName())
    return None


def _camera_value(name, v, fallback):
    """A camera attribute's value as sent: a token, a float vector as long as `fallback`, or a
    float."""
    if name in ALLOWED_TOKENS:
        return ("token", str(v))
    if isinstance(fallback, tuple):
        return _floats(list(v), len(fallback))
    return ("float", float(v))


def _is_xform_op(attr):
    """Whether `attr` is an attribute that names an xform op (of a known op type)."""
    if not attr:
        return False
    try:
        return bool(UsdGeom.XformOp(attr))
    except Tf.ErrorException:
        return False


def _order_ops(prim):
    """[(entry, attribute or None, inverse)] of `prim`'s `xformOpOrder` (empty where it is
    unauthored or unreadable): each entry's attribute where it is an xform op, else None;
    `!resetXformStack!` as (entry, None, False)."""
    order = prim.GetAttribute("xformOpOrder")
    try:
        names = [str(n) for n in order.Get()] if order and order.HasValue() and \
            not _mistyped(prim, order) else []
    except (Tf.ErrorException, TypeError):
        names = []
    out = []
    for name in names:
        inverse = name.startswith("!invert!")
        attr = prim.GetAttribute(name[len("!invert!"):] if inverse else name)
        out.append((name, attr if name != "!resetXformStack!" and _is_xform_op(attr) else None, inverse))
    return out


def _placement(prim, time):
    """(local matrix, whether it resets the transform stack, [(attribute, why) of each op
    skipped]) of `prim` at `time`, composed op by op as USD's transform computation does (C++),
    which skips an `xformOpOrder` entry naming no xform op of the prim, or an op whose value
    does not fit it, with a warning: its Python binding raises instead, so this is what the
    reader falls back on then."""
    m, reset, skipped = Gf.Matrix4d(1), False, []
    for k, (name, attr, inverse) in enumerate(_order_ops(prim)):
        if name == "!resetXformStack!":
            reset = reset or k == 0
            continue
        if attr is None:
            skipped.append(("xformOpOrder", "names '%s', which is not an xform op of the prim" % name))
            continue
        try:
            m = UsdGeom.XformOp(attr, inverse).GetOpTransform(time) * m
        except Tf.ErrorException:
            stack = attr.GetPropertyStack(Usd.TimeCode.Default())
            skipped.append((attr.GetName(), "a %s value does not fit its op"
                            % getattr(stack[0], "typeName", "") if stack else "its value does not fit its op"))
    return m, reset, skipped


def _op_times(x, interval):
    """The time samples within `interval` of Xformable `x`'s ops (what its
    GetTimeSamplesInInterval gives, also for a prim whose `xformOpOrder` that refuses)."""
    try:
        return x.GetTimeSamplesInInterval(interval)
    except Tf.ErrorException:
        times = set()
        for _, attr, _ in _order_ops(x.GetPrim()):
            if attr is not None:
                times.update(attr.GetTimeSamplesInInterval(interval))
        return sorted(times)


class _Placements:
    """World transforms at one time: UsdGeom.XformCache's, or, where it refuses a prim's
    transform (see _placement), composed op by op, each op skipped reported through
    `report(prim, attribute, why)`."""

    def __init__(self, time, report):
        self._cache, self._time, self._report = UsdGeom.XformCache(time), time, report

    def GetLocalToWorldTransform(self, prim):
        try:
            return self._cache.GetLocalToWorldTransform(prim)
        except Tf.ErrorException:
            m, p = Gf.Matrix4d(1), prim
            while p and not p.IsPseudoRoot():
                if UsdGeom.Xformable(p):
                    local, reset, skipped = _placement(p, self._time)
                    for attr, why in skipped:
                        self._report(p.GetPath(), attr, why)
                    m = m * local
                    if reset:
                        break
                p = p.GetParent()
            return m


def _rigidly_between(ma, mb, mm):
    """Whether matrix `mm` is (to 1e-4 of the motion and 0.25 degrees) what a rigid
    interpolation halfway from `ma` to `mb` gives: translations and scales averaged, rotations
    by the shortest arc."""
    ta, tb, tm = Gf.Transform(ma), Gf.Transform(mb), Gf.Transform(mm)
    pa, pb, pm = ta.GetTranslation(), tb.GetTranslation(), tm.GetTranslation()
    reach = max((pb - pa).GetLength(), 1e-3 * max(pa.GetLength(), pb.GetLength(), 1.0))
    if ((pa + pb) * 0.5 - pm).GetLength() > 1e-4 * reach + 1e-9:
        return False
    if ((ta.GetScale() + tb.GetScale()) * 0.5 - tm.GetScale()).GetLength() > 1e-4:
        return False
    qa, qb = ta.GetRotation().GetQuat(), tb.GetRotation().GetQuat()
    if Gf.Dot(qa, qb) < 0:
        qb = -qb
    half = Gf.Slerp(0.5, qa, qb)
    turn = (half.GetInverse() * tm.GetRotation().GetQuat()).GetNormalized()
    angle = 2.0 * math.degrees(math.acos(min(1.0, abs(turn.GetReal()))))
    return angle <= 0.25


# Byte payloads this large are kept by the reader, once sent, as a digest: what it compares
# the next sync's values with, not a second copy of every large array the delegate holds.
DIGEST_BYTES = 1 << 16


class _Digest:
    """A large byte payload already sent: its length and hash. Equal to the same bytes (and to
    a digest of them), so a sent state compares with a new one as the bytes would."""

    __slots__ = ("size", "sum")

    def __init__(self, data):
        self.size = len(data)
        self.sum = hashlib.sha1(data).digest()

    def __eq__(self, other):
        if isinstance(other, _Digest):
            return self.size == other.size and self.sum == other.sum
        if isinstance(other, (bytes, bytearray, memoryview)):
            return len(other) == self.size and hashlib.sha1(other).digest() == self.sum
        return NotImplemented

    __hash__ = None


def _digested(v):
    """`v` (a protocol value, a primvar tuple, or a part of one) with its large byte payloads
    replaced by digests."""
    if isinstance(v, (bytes, bytearray)):
        return _Digest(v) if len(v) >= DIGEST_BYTES else v
    if isinstance(v, tuple):
        d = tuple(_digested(x) for x in v)
        return v if all(a is b for a, b in zip(d, v)) else d
    return v


def _kept(st):
    """The state the reader keeps of `st` once sent: the same, large payloads digested (`st`
    itself where it has none)."""
    values = {k: _digested(samples) for k, samples in st.values.items()}
    primvars = {k: _digested(pv) for k, pv in st.primvars.items()}
    if all(values[k] is v for k, v in st.values.items()) and \
            all(primvars[k] is v for k, v in st.primvars.items()):
        return st
    out = _PrimState(st.kind, st.type, st.source)
    out.values, out.primvars, out.queries = values, primvars, st.queries
    return out


def rows(value):
    """How many tuples a sent array value holds (its payload may be a digest)."""
    def size(b):
        return b.size if isinstance(b, _Digest) else len(b)
    tag = value[0]
    if tag in ("floats", "doubles"):
        return size(value[2]) // ((4 if tag == "floats" else 8) * value[1])
    if tag == "ints":
        return size(value[1]) // 4
    raise ValueError("not an array value: %r" % (tag,))


def _stale_keys(old, new):
    """Whether `old` (the state last sent) has a key `new` lacks, or a key whose sample times
    differ from `new`'s."""
    for key, samples in old.values.items():
        now = new.values.get(key)
        if now is None or [t for t, _ in samples] != [t for t, _ in now]:
            return True
    return False


def send(delegate, path, key, value, time=None):
    """Sends one protocol value to the delegate."""
    tag = value[0]
    if tag in ("bool", "int", "float"):
        delegate.set(path, key, value[1], time)
    elif tag in ("token", "asset", "path", "string"):
        delegate.set(path, key, (tag, value[1]), time)
    elif tag == "paths":
        delegate.set(path, key, ("paths", list(value[1])), time)
    elif tag == "floats":
        delegate.set_array(path, key, value[2], value[1], "f", time)
    elif tag == "doubles":
        delegate.set_array(path, key, value[2], value[1], "d", time)
    elif tag == "ints":
        delegate.set_array(path, key, value[1], 1, "i", time)
    elif tag == "matrix":
        delegate.set_matrix(path, key, list(value[1]), time)
    else:
        raise ValueError("unknown value tag %r" % (tag,))


def decode(value):
    """A protocol value back as plain Python (for listings and tests)."""
    tag = value[0]
    if tag == "floats":
        a = np.frombuffer(value[2], dtype=np.float32)
        return a.reshape(-1, value[1]) if value[1] > 1 else a
    if tag == "doubles":
        a = np.frombuffer(value[2], dtype=np.float64)
        return a.reshape(-1, value[1])
    if tag == "ints":
        return np.frombuffer(value[1], dtype=np.int32)
    return value[1]


class _PrimState:
    """What one delegate prim should hold: type, values (key -> [(time, value)]), primvars."""

    __slots__ = ("kind", "type", "source", "values", "primvars", "queries")

    def __init__(self, kind, type_name, source):
        self.kind = kind          # rprim | sprim | bprim
        self.type = type_name
        self.source = source      # the USD path it comes from
        self.values = {}
        self.primvars = {}        # name -> (interpolation, floats bytes, tuple, indices bytes|None)
        self.queries = []         # a light's link collections that need USD's query: (name, query)

    def set(self, key, value, samples=None):
        if samples is not None:
            self.values[key] = tuple(samples)
        elif value is not None:
            self.values[key] = ((None, value),)


# Whether native instances alike are placed from the first (Reader._instance_shortcut); False
# walks every instance, the reference the shortcut is checked against.
SHARE_INSTANCES = True

# On a stage with held interpolation a value jumps at each time sample: the reader also samples
# this fraction of the shutter before each one, so that the renderer's linear interpolation over
# the shutter is a step (a ramp over 1/4096 of the exposure).
HELD_STEP = 2.0 ** -12


def _mat_key(m):
    return tuple(float(m[i][j]) for i in range(4) for j in range(4))


class Reader:
    """Reads a USD stage into a Tide RenderDelegate and keeps it in step with edits."""

    def __init__(self, stage, delegate, options=None):
        self.stage = stage
        self.delegate = delegate
        self.options = options or Options()
        self.problems = []            # every distinct problem found so far
        self._seen = set()            # (prim, attribute) already reported
        self._pending = []            # problems found since the last commit
        self._sent = {}               # delegate path -> _PrimState last sent
        self._prim_ids = {}            # delegate path -> primId
        self._prim_id_owners = {}      # primId -> delegate path
        self._blur = 1.0              # motion:blurScale of the prim being read
        self._changed = []
        self._instance_sources = set()
        self._depends = {}            # prim read on others' behalf -> the prims read from it
        self._skel_sources = set()    # Skeleton, SkelAnimation, BlendShape paths skinning read
        self._composed_errors = set()  # USD's composition errors named so far, as they last
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, self._on_changed, stage)
        self.frame = self._initial_frame()
        self.settings_path = None     # delegate path of the renderSettings sprim
        self.settings_prim = None     # the UsdRenderSettings prim, if any
        self.camera_path = None
        self.products = []
        self.renders = []             # [[Product]]: products rendered together, in order
        self.render_index = 0         # which of them the delegate holds now
        self.resolution = (0, 0)
        self.sample_target = 0
        self._partial = False         # whether the sync under way is a partial one
        self._bound_paths = None      # see _bound_materials

    # -- public ---------------------------------------------------------------------------
    def populate(self):
        """Creates every prim and sets every attribute; returns the problems found so far."""
        self._sync(None)
        return list(self._pending)

    def commit(self):
        """Commits to the delegate; returns the problems not reported before (a render's
        engine reports what it found while preparing the scene to the first commit after it
        is built)."""
        return self._take(self.delegate.commit_resources())

    def check(self):
        """Commits, then has the delegate prepare the scene as a render would (the renderer's
        validation and world build) without rendering; returns the problems not reported
        before."""
        return self._take(self.delegate.check_render())

    def _take(self, items):
        found = list(self._pending)
        self._pending = []
        for item in items or []:
            p = Problem.of_delegate(*item)
            # the delegate names a primvar without its namespace: name the attribute authored
            prim = self.stage.GetPrimAtPath(p.prim) if Sdf.Path.IsValidPathString(p.prim) else None
            if prim and p.attribute and not prim.HasAttribute(p.attribute) and \
                    prim.HasAttribute("primvars:" + p.attribute):
                p = Problem(p.prim, "primvars:" + p.attribute, p.message)
            # without a settings prim, what the stand-in settings carry is the stage's own
            # metadata (metersPerUnit, timeCodesPerSecond): named on the stage's root
            if p.prim == SETTINGS_FALLBACK_PATH and self.settings_prim is None:
                p = Problem("/", p.attribute, p.message)
            found.append(p)
        new = []
        for p in found:
            key = (p.prim, p.attribute)
            if key in self._seen:
                continue
            self._seen.add(key)
            self.problems.append(p)
            new.append(p)
        return new

    def load(self):
        """populate() + commit(): returns the problems."""
        self.populate()
        return self.commit()

    def update(self):
        """Re-sets the prims affected by edits made through usd-core since the last sync,
        then commits. Returns the new problems (the delegate restarts a running pass)."""
        changed, self._changed = self._changed, []
        # texture and VDB files rewritten on disk are read again (no USD edit tells of them)
        reread = self._reread_files()
        # a stage's interpolation type is set at run time, with no notice
        if not changed and self._stage_held() == self._held:
            return self.commit() if reread else []
        roots = self._roots_for(changed)
        if self.options.frame is None and self._initial_frame() != self.frame:
            # the stage's startTimeCode moved the frame rendered: everything is read there
            self.frame = self._initial_frame()
            roots = None
        self._sync(roots)
        return self.commit()

    def set_frame(self, frame):
        """Renders time code `frame` from now on (a viewer's time scrubbing): every prim is
        read at it and only what differs reaches the delegate, which restarts a running pass.
        Returns the new problems."""
        frame = float(frame)
        if not math.isfinite(frame):
            raise ValueError("frame must be finite, got %r" % frame)
        self.options.frame = frame
        if frame == self.frame:
            return []
        self.frame = frame
        self._changed = []
        self._sync(None)
        return self.commit()

    def select_render(self, index):
        """Makes the delegate hold render `index` of `renders`: its lead product's resolution,
        camera and settings (a full re-sync sends only what differs). Returns new problems."""
        if not 0 <= index < max(1, len(self.renders)):
            raise IndexError("render %d of %d" % (index, len(self.renders)))
        self.render_index = index
        self._sync(None)
        return self.commit()

    def render_pass(self):
        """Creates a render pass and starts it on the selected camera and buffers."""
        rp = self.delegate.create_render_pass()
        # the camera as the settings sprim names it (the reader sends the one it resolved):
        # an edit that retargets the settings' camera then reaches the running pass
        rp.execute("", self.bindings(), self.settings_path)
        return rp

    def bindings(self, every_product=False):
        """(sourceName, buffer) of the products in the current render (of all of them)."""
        out, seen = [], set()
        prods = self.products if every_product or not self.renders \
            else self.renders[self.render_index]
        for prod in prods:
            for source, buf in prod.vars:
                if buf not in seen:
                    seen.add(buf)
                    out.append((source, buf))
        return out

    def sent(self):
        """Delegate path -> (type, {key: [(time, value)]}) of what was sent (for listings):
        byte payloads of DIGEST_BYTES or more are digests there (`rows` counts them)."""
        return {p: (s.type, dict(s.values)) for p, s in self._sent.items()}

    def close(self):
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None

    # -- problems -------------------------------------------------------------------------
    def problem(self, prim, attribute, message):
        self._pending.append(Problem(str(prim), attribute, message))

    # -- change tracking ------------------------------------------------------------------
    def _on_changed(self, notice, sender):
        self._changed.extend(notice.GetResyncedPaths())
        self._changed.extend(notice.GetChangedInfoOnlyPaths())

    def _roots_for(self, changed):
        roots = set()
        for path in changed:
            prim_path = path.GetPrimPath() if path.IsPropertyPath() else path
            if prim_path == Sdf.Path.absoluteRootPath:
                return None
            name = path.name if path.IsPropertyPath() else ""
            if name.startswith("collection:"):
                return None
            prim = self.stage.GetPrimAtPath(prim_path)
            if prim and (prim.IsInstanceProxy() or prim.IsInstance() or prim.IsInPrototype()):
                return None
            for src in self._instance_sources:
                if prim_path.HasPrefix(src) or src.HasPrefix(prim_path):
                    return None
            # prims read on another's behalf (a shader outside the material that uses it, a
            # volume's field prims): that prim is read again
            for dep, dependents in self._depends.items():
                if prim_path.HasPrefix(dep) or dep.HasPrefix(prim_path):
                    roots.update(dependents)
            # skinned meshes read Skeleton, SkelAnimation and BlendShape prims that may lie
            # anywhere: an edit to one (or to a prim that was one) re-syncs everything
            if skel.is_source(prim) or any(prim_path.HasPrefix(s) or s.HasPrefix(prim_path)
                                           for s in self._skel_sources):
                return None
            root = prim_path
            if prim and prim.IsA(UsdGeom.Subset):
                root = prim_path.GetParentPath()
            p = prim
            if not p:
                # a prim removed (or deactivated): what held it is read again, e.g. the
                # material a deleted shader belonged to
                p = self.stage.GetPrimAtPath(prim_path.GetParentPath())
            while p and p.GetPath() != Sdf.Path.absoluteRootPath:
                if p.IsA(UsdShade.Material):
                    root = p.GetPath()
                if p.IsA(UsdGeom.PointInstancer):
                    return None
                p = p.GetParent()
            # the skinning of a SkelRoot's meshes depends on bindings inherited within it
            outer = skel.skel_root(self.stage, prim_path)
            if outer:
                root = outer.GetPath()
            roots.add(root)
        out = []
        for r in sorted(roots, key=lambda p: p.pathElementCount):
            if not any(r.HasPrefix(o) for o in out):
                out.append(r)
        return out

    # -- sync -----------------------------------------------------------------------------
    def _stage_held(self):
        """Whether the stage holds values between time samples (UsdStage's interpolation type
        held) rather than interpolating them linearly."""
        return self.stage.GetInterpolationType() == Usd.InterpolationTypeHeld

    def _initial_frame(self):
        if self.options.frame is not None:
            return float(self.options.frame)
        if self.stage.HasAuthoredTimeCodeRange():
            return float(self.stage.GetStartTimeCode())
        return 0.0

    def _composition_problems(self):
        """Names what USD could not compose (a sublayer, reference or payload whose file is
        missing, an arc in a cycle): the stage renders without it. Each once while it lasts."""
        now = set()
        for e in self.stage.GetCompositionErrors():
            message = str(e).strip()
            kind = str(e.errorType)
            if "Sublayer" in kind:
                attribute = "subLayers"
            elif " for payload " in message:
                attribute = "payload"
            elif " for reference " in message:
                attribute = "references"
            else:
                attribute = "composition"
            now.add((str(e.rootSite.path), attribute, message))
        for path, attribute, message in sorted(now - self._composed_errors):
            message = message.rstrip(".;")
            if message.endswith("; skipping"):
                message = message[:-len("; skipping")]
            self.problem(path, attribute, "%s; the stage renders without it" % message)
        self._composed_errors = now

    def _sync(self, roots):
        desired = {}
        full = roots is None
        self._composition_problems()
        if full:
            roots = [Sdf.Path.absoluteRootPath]
            self._instance_sources = set()
            self._skel_sources = set()
            self._depends = {}
        self._desired = desired
        self._partial = not full
        self._bound_paths = None
        self._skinning = skel.Skinning(self.stage, self.problem)
        placed = (getattr(self, "_motion", None), getattr(self, "_shutter", None),
                  getattr(self, "_binding_purposes", None), getattr(self, "_purposes", None),
                  getattr(self, "_held", None))
        self._held = self._stage_held()
        self._eval_settings()
        if not full and placed != (self._motion, self._shutter, self._binding_purposes,
                                   self._purposes, self._held):
            # the shutter (or motion blur, or the stage's interpolation) changed: every prim's
            # samples over it are taken anew; other binding purposes or included purposes:
            # every prim is read again (prims of a purpose newly included were never read)
            return self._sync(None)
        self._groups = {}
        # native instances read from the first like them (see _instance_shortcut)
        self._reps, self._recording, self._signatures, self._xforms = {}, [], {}, None
        for root in roots:
            prim = self.stage.GetPrimAtPath(root)
            if prim and prim.IsActive():
                self._walk(prim)
        self._reps, self._signatures, self._xforms = {}, {}, None
        if not full and self._groups:
            return self._sync(None)
        if full:
            self._emit_instance_groups()
            # the members (a million instances' paths and matrices) are in the states now
            for grp in self._groups.values():
                grp["members"] = None
        self._resolve_link_queries(desired, roots)
        # Destroy what came from the walked subtrees and is gone.
        for path in list(self._sent):
            st = self._sent[path]
            if path in desired:
                continue
            if path == DEFAULT_CAMERA_PATH or any(Sdf.Path(st.source).HasPrefix(r) for r in roots):
                if st.type == "material" and not full and self._material_exists(path):
                    # still bound by prims outside the walked subtrees
                    continue
                self.delegate.destroy_prim(path)
                del self._sent[path]
        for path, st in desired.items():
            self._apply(path, st)
        # the reader keeps what it sent (large arrays as digests), not what it evaluated
        desired.clear()

    def _resolve_link_queries(self, desired, roots):
        """Sends the link collections only USD's membership query can resolve as explicit lists
        of the names collections match (a prim's path, or each native instance's): of every
        prim the delegate will hold after this sync (what it held outside the synced subtrees
        `roots`, and what they now give), so a light outside them is updated too."""
        if not any(st.queries for st in desired.values()) and \
                not any(st.queries for st in self._sent.values()):
            return
        states = {p: st for p, st in self._sent.items()
                  if not any(Sdf.Path(st.source).HasPrefix(r) for r in roots)}
        states.update(desired)
        lights = [(p, st) for p, st in states.items() if st.queries]
        names = []
        for p, st in states.items():
            if st.kind == "rprim":
                inst = st.values.get("instancePaths")
                names.extend(inst[0][1][1] if inst else (p,))
        paths = [(n, Sdf.Path(n)) for n in names]
        for p, st in lights:
            new = _PrimState(st.kind, st.type, st.source)
            new.values, new.primvars, new.queries = dict(st.values), st.primvars, st.queries
            for which, query in st.queries:
                base = "collection:%s:" % which
                new.set(base + "includes", ("paths", tuple(sorted(
                    n for n, sp in paths if query.IsPathIncluded(sp)))))
                new.set(base + "excludes", ("paths", ()))
                new.set(base + "includeRoot", ("bool", False))
                new.set(base + "expansionRule", ("token", "explicitOnly"))
            if p in desired or new.values != st.values:
                desired[p] = new

    def _bound_materials(self):
        """Paths of the materials prims the delegate holds are bound to, found once per sync
        when a partial one walks a material the delegate does not hold: one deactivated or
        removed and brought back, whose prims outside the walk await it."""
        if self._bound_paths is None:
            self._bound_paths = {
                v[1] for st in self._sent.values() if st.kind == "rprim"
                for _, v in st.values.get("material", ()) if v and v[0] == "path"}
        return self._bound_paths

    def _material_exists(self, path):
        prim = self.stage.GetPrimAtPath(path)
        return bool(prim) and prim.IsActive() and prim.IsA(UsdShade.Material)

    def _apply(self, path, st):
        old = self._sent.get(path)
        d = self.delegate
        if old is not None and (old.type != st.type or set(old.primvars) != set(st.primvars)
                                or _stale_keys(old, st)):
            # the delegate keeps what it was sent: a prim that lost an attribute, or whose
            # samples are now at other times (a static value that starts moving, a shutter
            # edit), is sent anew so that no old value or sample lingers
            d.destroy_prim(path)
            old = None
        if old is None:
            create = {"rprim": d.create_rprim, "sprim": d.create_sprim,
                      "bprim": d.create_bprim}[st.kind]
            if not create(st.type, path):
                self.problem(path, "type", "the delegate does not know prim type '%s'" % st.type)
                return
        for key, samples in list(st.values.items()):
            if old is not None and old.values.get(key) == samples:
                continue
            try:
                for time, value in samples:
                    send(d, path, key, value, time)
            except Exception as e:  # the delegate refused the value: drop that input
                self.problem(path, key, "rejected by the delegate (%s); dropped" % e)
                del st.values[key]
        for name, pv in list(st.primvars.items()):
            if old is not None and old.primvars.get(name) == pv:
                continue
            interp, data, tsize, idx = pv
            try:
                d.set_primvar(path, name, interp, data, tsize, idx)
            except Exception as e:
                self.problem(path, "primvars:" + name, "rejected by the delegate (%s); dropped"
                             % e)
                del st.primvars[name]
        self._sent[path] = _kept(st)

    # -- traversal ------------------------------------------------------------------------
    def _included(self, imageable):
        purpose = imageable.ComputePurpose()
        return self._purpose_included(purpose), purpose

    def _purpose_included(self, purpose):
        """Whether the settings' includedPurposes take `purpose` (an unknown token, reported
        where it is authored, reads as the default)."""
        if purpose not in ALLOWED_TOKENS["purpose"]:
            purpose = UsdGeom.Tokens.default_
        return purpose in self._purposes

    def _check_imageable_tokens(self, prim, imageable):
        """Names an authored visibility or purpose that is not one of USD's tokens (they then
        read as `inherited` and `default`)."""
        for attr in (imageable.GetVisibilityAttr(), imageable.GetPurposeAttr()):
            if attr and attr.HasAuthoredValue():
                v = attr.Get(self._time(0))
                allowed = ALLOWED_TOKENS[attr.GetName()]
                if v not in allowed:
                    self.problem(prim.GetPath(), attr.GetName(),
                                 "unknown token '%s'; using '%s'" % (v, allowed[0]))

    def _walk(self, root):
        pred = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
        it = iter(Usd.PrimRange(root, pred))
        for prim in it:
            try:
                self._visit(prim, it)
            except Exception as e:  # a value the reader cannot use (a wrongly typed attribute)
                found = self._culprit(prim)
                if found is None:
                    why = (str(e).strip().splitlines() or [type(e).__name__])[-1].strip()
                    found = (prim.GetPath(), "", "cannot be read (%s)" % why)
                where, attr, why = found
                self.problem(where, attr, "%s; %s dropped" % (why, "the prim is" if where ==
                                                              prim.GetPath() else
                                                              "%s is" % prim.GetPath()))
                self._desired.pop(str(prim.GetPath()), None)
                it.PruneChildren()

    def _visit(self, prim, it):
        """Reads one prim of the walk (`it` prunes what it need not enter)."""
        type_name = prim.GetTypeName()
        if prim.IsA(UsdShade.Material):
            path = str(prim.GetPath())
            if path in self._sent or (self._partial and path in self._bound_materials()):
                self._eval_material(prim)
            it.PruneChildren()
            return
        if prim.IsA(UsdRender.SettingsBase) or prim.IsA(UsdRender.Var):
            it.PruneChildren()
            return
        img = UsdGeom.Imageable(prim)
        if img:
            self._check_imageable_tokens(prim, img)
            if img.ComputeVisibility(self._time(0)) == UsdGeom.Tokens.invisible:
                # visibility hides geometry and lights; a camera is looked through all the same
                for p in Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
                    if p.IsA(UsdGeom.Camera):
                        self._unshared()
                        self._eval_camera(p)
                it.PruneChildren()
                return
            ok, _ = self._included(img)
            # includedPurposes chooses geometry (Hydra's render tags): cameras and lights are
            # read whatever their purpose
            if not ok and not (prim.IsA(UsdGeom.Camera) or type_name in LIGHTS):
                # not drawn, but a descendant that authors its own purpose may be (an
                # authored purpose overrides the inherited one); an instancer's prototypes
                # are drawn only through it
                if prim.IsA(UsdGeom.PointInstancer):
                    it.PruneChildren()
                return
        if prim.IsA(UsdGeom.PointInstancer):
            self._unshared()
            self._eval_instancer(prim)
            it.PruneChildren()
            return
        if prim.IsInstance():
            self._instance_sources.add(prim.GetPath())
            if self._instance_shortcut(prim, it):
                return
        if type_name in GPRIMS:
            # a skinned gprim in a native instance is posed by that instance's skeleton
            # and animation: sent on its own, at its instance proxy's path
            if prim.IsInstanceProxy() and not self._posed_apart(prim):
                self._collect_instanced(prim)
            else:
                self._unshared()
                self._eval_gprim(prim, str(prim.GetPath()), str(prim.GetPath()))
        elif type_name in LIGHTS:
            # lights, cameras and portals are sent at their own paths: each instance's its own
            self._unshared()
            self._eval_light(prim)
        elif prim.IsA(UsdGeom.Camera):
            self._unshared()
            self._eval_camera(prim)
        elif prim.IsA(UsdLux.PortalLight):
            self._unshared()
            self._eval_portal(prim)
        elif prim.IsA(UsdLux.BoundableLightBase) or prim.IsA(UsdLux.NonboundableLightBase):
            self.problem(prim.GetPath(), "type",
                         "light type '%s' is not supported; dropped" % type_name)
        elif prim.IsA(UsdGeom.Gprim):
            self.problem(prim.GetPath(), "type",
                         "prim type '%s' is not supported; dropped" % type_name)

    # -- time and transforms --------------------------------------------------------------
    def _time(self, offset):
        return Usd.TimeCode(self.frame + self._blur * offset)

    # motion:blurScale (UsdGeomMotionAPI), as its guidance says: a prim with scale s is sampled
    # over the shutter window scaled by s about the frame, and its samples are handed on at
    # their times over s (velocities times s, accelerations times s squared); s = 0 holds it
    # still. `_blur` is the scale of the prim being read (1 elsewhere).
    @property
    def _moving(self):
        return self._motion and self._blur > 0.0

    def _window(self):
        """The scene times a moving prim is sampled over: the shutter scaled by its blurScale."""
        lo, hi = self._shutter
        return Gf.Interval(self.frame + self._blur * lo, self.frame + self._blur * hi)

    def _offset(self, t):
        """The shutter offset (frames) at which the sample at scene time `t` is handed on."""
        return (t - self.frame) / self._blur

    def _shutter_offsets(self, times):
        """The shutter's ends and the offsets of scene `times` (samples within `_window()`),
        sorted: where a moving prim is sampled. On a stage with held interpolation each sample
        inside the shutter also gets an offset HELD_STEP of the shutter before it, where the
        value is still the one before: the renderer's interpolation between the two makes
        the jump."""
        lo, hi = self._shutter
        authored = {self._offset(t) for t in times}
        offs = {lo, hi} | authored
        if self._held:
            step = HELD_STEP * (hi - lo)
            offs |= {o - step for o in authored if lo + step < o <= hi}
        return sorted(offs)

    def _time_fn(self):
        """`_time` with the blurScale of the prim being read kept, for functions called after
        (a nested instancer calls its outer one's under its own scale)."""
        frame, blur = self.frame, self._blur
        return lambda o: Usd.TimeCode(frame + blur * o)

    @contextlib.contextmanager
    def _blurred(self, prim):
        """Reads `prim` (and what it places) with its inherited motion:blurScale."""
        before = self._blur
        scale = 1.0
        if self._motion:
            scale = float(UsdGeom.MotionAPI(prim).ComputeMotionBlurScale(Usd.TimeCode(self.frame)))
            if not (scale >= 0.0 and math.isfinite(scale)):
                self.problem(prim.GetPath(), "motion:blurScale", "%g is not in [0, inf); using 1"
                             % scale)
                scale = 1.0
        self._blur = scale
        try:
            yield
        finally:
            self._blur = before

    def _motion_offsets(self, prims):
        """Offsets (frames) at which to sample transforms: shutter ends + authored samples."""
        if not self._moving:
            return [0.0]
        return self._shutter_offsets(self._xform_times(prims))

    def _xform_times(self, prims):
        """The scene times within `_window()` of the transform samples of `prims` and their
        ancestors."""
        interval = self._window()
        times = set()
        for p in prims:
            x = UsdGeom.Xformable(p)
            while x:
                times.update(_op_times(x, interval))
                parent = x.GetPrim().GetParent()
                x = UsdGeom.Xformable(parent) if parent else None
        return times

    def _xform_samples(self, fn, prims):
        """[(offset|None, matrix value)] of fn(time): one sample unless it moves. Between two
        samples the renderer interpolates a rigid motion (translation along the chord, rotation
        by the shortest arc); where USD's own transform at the middle differs from that (a
        child turning round its parent's pivot, a turn of 180 degrees or more, a whole turn
        whose ends agree) the interval is halved, down to 1/32 of it."""
        offsets = self._motion_offsets(prims)
        mats = [(o, fn(self._time(o))) for o in offsets]
        # held values keep still between their samples: nothing to follow there
        if len(mats) > 1 and not self._held:
            refined = [mats[0]]
            for (a, ma), (b, mb) in zip(mats, mats[1:]):
                refined.extend(self._between(fn, a, ma, b, mb, 5))
                refined.append((b, mb))
            mats = refined
        keys = [_mat_key(m) for _, m in mats]
        if all(k == keys[0] for k in keys):
            return [(None, ("matrix", keys[0]))]
        return [(o, ("matrix", k)) for (o, _), k in zip(mats, keys)]

    def _between(self, fn, a, ma, b, mb, depth):
        """The samples of fn strictly between offsets a and b needed for the renderer's
        interpolation to follow it (see _xform_samples)."""
        if depth == 0:
            return []
        m = 0.5 * (a + b)
        mm = fn(self._time(m))
        if _rigidly_between(ma, mb, mm):
            return []
        return (self._between(fn, a, ma, m, mm, depth - 1) + [(m, mm)] +
                self._between(fn, m, mm, b, mb, depth - 1))

    def _world(self, prim):
        return lambda t: self._world_at(prim, t)

    def _world_at(self, prim, t):
        """`prim`'s world matrix at time `t` (see _placement for a prim whose transform USD's
        Python binding refuses)."""
        try:
            return UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(t)
        except Tf.ErrorException:
            return self._placements(t).GetLocalToWorldTransform(prim)

    def _placements(self, t):
        """World transforms at time `t` (a transform cache that skips, and reports, ops as USD
        does; see _Placements)."""
        return _Placements(t, lambda path, attr, why: self.problem(
            path, attr, "%s; the op is skipped, as USD skips it" % why))

    # -- render settings, products, camera selection --------------------------------------
    def _eval_settings(self):
        o = self.options
        stage = self.stage
        path = o.settings
        if path is None:
            meta = stage.GetMetadata("renderSettingsPrimPath")
            path = meta or None
        settings = None
        if path:
            prim = stage.GetPrimAtPath(path)
            if prim and prim.IsA(UsdRender.Settings):
                settings = UsdRender.Settings(prim)
            elif o.settings is not None:
                raise LookupError("no UsdRenderSettings prim at %s" % path)
            else:
                self.problem("/", "renderSettingsPrimPath",
                             "%s is not a UsdRenderSettings prim; using defaults" % path)
        if settings is None and o.settings is None:
            for prim in stage.Traverse():
                if prim.IsA(UsdRender.Settings):
                    settings = UsdRender.Settings(prim)
                    break
        self.settings_prim = settings.GetPrim() if settings else None
        spath = str(settings.GetPath()) if settings else SETTINGS_FALLBACK_PATH
        self.settings_path = spath
        st = _PrimState("sprim", "renderSettings", spath if settings else "/")

        def get(attr, fallback):
            if settings is None or not attr:
                return fallback
            # at the frame: settings may be animated (a resolution, disableMotionBlur, ...)
            return self._checked(spath, attr.GetName(), attr.Get(self._time(0)), fallback)

        sp = settings.GetPrim() if settings else None
        # UsdRenderSettingsBase attributes a product authors override the settings' for it.
        # Products whose resolved settings agree are rendered together; each other group is a
        # render of its own (select_render), led by its first product.
        products_ = [stage.GetPrimAtPath(t) for t in settings.GetProductsRel().GetForwardedTargets()] \
            if settings else []
        products_ = [q for q in products_ if q and q.IsA(UsdRender.Product)]

        def base_for(q, name, fallback):
            if q is not None:
                a = q.GetAttribute(name)
                if a and a.HasAuthoredValue():
                    return self._checked(str(q.GetPath()), name, a.Get(self._time(0)), fallback)
            return get(sp.GetAttribute(name) if sp else None, fallback)

        def camera_for(q):
            if o.camera:
                return (o.camera,)
            rel = q.GetRelationship("camera") if q is not None else None
            targets = rel.GetForwardedTargets() if rel else []
            return tuple(str(t) for t in (targets or settings.GetCameraRel().GetForwardedTargets()))

        overridden = {key for opt, key in OPTION_KEYS.items() if getattr(o, opt) is not None}
        if o.pixel_filter is not None or o.pixel_filter_width is not None:
            overridden.add("tide:pixelFilter:width")

        def key_for(q):
            names = [n for n in BASE_ATTRS + tuple(SETTINGS_TIDE) if n not in overridden]
            return tuple(repr(base_for(q, n, None)) for n in names) + (camera_for(q),)

        groups = {}
        for i, q in enumerate(products_):
            k = 0 if o.single_image else key_for(q)
            groups.setdefault(k, []).append(i)
        self._render_groups = list(groups.values()) or [[0]]
        self.render_index = min(self.render_index, len(self._render_groups) - 1)
        lead = products_[self._render_groups[self.render_index][0]] if products_ else None

        def base(name, fallback):
            return base_for(lead, name, fallback)

        if o.single_image:
            for q in products_[1:]:
                for name in BASE_ATTRS + tuple(SETTINGS_TIDE):
                    if name in overridden:
                        continue
                    a = q.GetAttribute(name)
                    if a and a.HasAuthoredValue() and a.Get() != base(name, None):
                        self.problem(str(q.GetPath()), name, "differs from the first product's; "
                                     "one image serves every product, rendered with the first's")
                if camera_for(q) != camera_for(lead):
                    self.problem(str(q.GetPath()), "camera", "differs from the first product's; "
                                 "one image serves every product, rendered with the first's")
        res = base("resolution", Gf.Vec2i(1920, 1080))
        w, h = int(res[0]), int(res[1])
        if w <= 0 or h <= 0:
            self.problem(spath, "resolution", "resolution %dx%d is not positive; using 1920x1080"
                         % (w, h))
            w, h = 1920, 1080
        elif w > MAX_IMAGE_SIDE or h > MAX_IMAGE_SIDE:
            self.problem(spath, "resolution", "resolution %dx%d is over %d pixels a side; using "
                         "1920x1080" % (w, h, MAX_IMAGE_SIDE))
            w, h = 1920, 1080
        if o.width:
            h = max(1, int(round(h * o.width / float(w))))
            w = int(o.width)
        self.resolution = (w, h)
        st.set("resolution", _ints([w, h]))
        st.set("pixelAspectRatio", ("float", float(base("pixelAspectRatio", 1.0))))
        st.set("aspectRatioConformPolicy", ("token", str(base("aspectRatioConformPolicy",
                                                             "expandAperture"))))
        st.set("dataWindowNDC", _floats(list(base("dataWindowNDC", Gf.Vec4f(0, 0, 1, 1))), 4))
        dmb = bool(base("disableMotionBlur", False))
        self._instantaneous = bool(get(settings.GetInstantaneousShutterAttr() if settings
                                       else None, False))
        ddof = bool(base("disableDepthOfField", False))
        st.set("disableMotionBlur", ("bool", dmb))
        st.set("disableDepthOfField", ("bool", ddof))
        binding = [str(t) for t in get(settings.GetMaterialBindingPurposesAttr() if settings
                                       else None, ["full", ""])]
        for t in binding:
            if t not in BINDING_PURPOSES:
                self.problem(spath, "materialBindingPurposes", "unknown purpose '%s'; ignored" % t)
        self._binding_purposes = [t for t in binding if t in BINDING_PURPOSES]
        purposes = list(get(settings.GetIncludedPurposesAttr() if settings else None,
                            ["default", "render"]))
        self._purposes = set(purposes)
        st.set("includedPurposes", ("paths", tuple(purposes)))
        st.set("renderingColorSpace", ("token", str(get(
            sp.GetAttribute("renderingColorSpace") if sp else None, "") or "lin_rec709")))
        for key, fb in SETTINGS_TIDE.items():
            # the first product's own value, else the settings'
            v = base(key, fb)
            if key in ALLOWED_TOKENS and v not in ALLOWED_TOKENS[key]:
                self.problem(spath, key, "unknown token '%s'; using '%s'" % (v, fb))
                v = fb
            if isinstance(fb, int) and not isinstance(fb, bool):
                v = int(v)
            elif isinstance(fb, float):
                v = float(v)
            if key == "tide:samples" and v < 1:
                self.problem(spath, key, "%d is not a positive sample count; using %d" % (v, fb))
                v = fb
            st.set(key, convert(v))
        if o.spp is not None:
            st.set("tide:samples", ("int", int(o.spp)))
        if o.seed is not None:
            st.set("tide:seed", ("int", int(o.seed)))
        if o.threads is not None:
            st.set("tide:threads", ("int", int(o.threads)))
        if o.integrator is not None:
            if o.integrator not in ALLOWED_TOKENS["tide:integrator"]:
                raise LookupError("unknown integrator '%s' (expected one of: %s)"
                                  % (o.integrator, ", ".join(ALLOWED_TOKENS["tide:integrator"])))
            st.set("tide:integrator", ("token", str(o.integrator)))
        if o.time_budget is not None:
            st.set("tide:time:budget", ("float", float(o.time_budget)))
        if o.max_depth is not None:
            st.set("tide:maxDepth", ("int", int(o.max_depth)))
        if o.pixel_filter is not None:
            if o.pixel_filter not in ALLOWED_TOKENS["tide:pixelFilter"]:
                raise LookupError("unknown pixel filter '%s' (expected one of: %s)"
                                  % (o.pixel_filter, ", ".join(ALLOWED_TOKENS["tide:pixelFilter"])))
            st.set("tide:pixelFilter", ("token", str(o.pixel_filter)))
            if o.pixel_filter_width is None:
                # the settings' width was meant for their filter: the new one takes its own
                st.set("tide:pixelFilter:width", ("float", 0.0))
        if o.pixel_filter_width is not None:
            st.set("tide:pixelFilter:width", ("float", float(o.pixel_filter_width)))
        if o.adaptive_threshold is not None:
            st.set("tide:adaptive:threshold", ("float", float(o.adaptive_threshold)))
        self.sample_target = st.values["tide:samples"][0][1][1]
        st.set("timeCodesPerSecond", ("float", float(stage.GetTimeCodesPerSecond())))
        # only where authored: USD's fallback (0.01, centimetres) would shrink every unauthored
        # stage's metres a hundredfold
        if UsdGeom.StageHasAuthoredMetersPerUnit(stage):
            st.set("metersPerUnit", ("float", float(UsdGeom.GetStageMetersPerUnit(stage))))
        # water depth is measured down the up axis
        st.set("upAxis", ("token", str(UsdGeom.GetStageUpAxis(stage))))

        # Camera selection: --camera, the settings' camera, else the first camera.
        cam = None
        if o.camera:
            cp = stage.GetPrimAtPath(o.camera)
            if not (cp and cp.IsA(UsdGeom.Camera)):
                raise LookupError("no UsdGeomCamera at %s" % o.camera)
            cam = cp
        elif settings is not None:
            targets = camera_for(lead)
            if targets:
                cp = stage.GetPrimAtPath(targets[0])
                if cp and cp.IsA(UsdGeom.Camera):
                    cam = cp
                else:
                    self.problem(spath, "camera", "%s is not a camera" % targets[0])
        if cam is None:
            for prim in stage.Traverse():
                if prim.IsA(UsdGeom.Camera):
                    cam = prim
                    break
        if cam is None:
            self.camera_path = DEFAULT_CAMERA_PATH
            self._default_camera(spath)
        else:
            self.camera_path = str(cam.GetPath())
            self._default_view = None
        st.set("camera", ("path", self.camera_path))
        self._shutter = (0.0, 0.0)
        if cam is not None:
            c = UsdGeom.Camera(cam)
            lo = c.GetShutterOpenAttr().Get(self._time(0))
            hi = c.GetShutterCloseAttr().Get(self._time(0))
            lo = 0.0 if lo is None else float(lo)
            hi = 0.0 if hi is None else float(hi)
            # closing before it opens, the camera sees nothing (the renderer reports it and
            # renders black); instantaneousShutter (deprecated) closes it as it opens
            if hi < lo or self._instantaneous:
                hi = lo
            self._shutter = (lo, hi)
        self._motion = (not dmb) and self._shutter[1] > self._shutter[0]
        self._desired[spath] = st

        # Products and their vars -> render buffers.
        products = []
        if settings is not None:
            names = {}
            for ppath in settings.GetProductsRel().GetForwardedTargets():
                pprim = stage.GetPrimAtPath(ppath)
                if not (pprim and pprim.IsA(UsdRender.Product)):
                    self.problem(spath, "products", "%s is not a UsdRenderProduct" % ppath)
                    continue
                prod = UsdRender.Product(pprim)
                # a file name per frame is a time-sampled productName
                name = str(prod.GetProductNameAttr().Get(self._time(0)) or pprim.GetName() + ".exr")
                if name in names:
                    stem, ext = os.path.splitext(name)
                    other, k = names[name], 2
                    while "%s_%d%s" % (stem, k, ext) in names:
                        k += 1
                    renamed = "%s_%d%s" % (stem, k, ext)
                    self.problem(ppath, "productName", "'%s' is %s's too; written as '%s'"
                                 % (name, other, renamed))
                    name = renamed
                names[name] = str(ppath)
                vars_, types = [], {}
                for vpath in prod.GetOrderedVarsRel().GetForwardedTargets():
                    vprim = stage.GetPrimAtPath(vpath)
                    if not (vprim and vprim.IsA(UsdRender.Var)):
                        self.problem(ppath, "orderedVars", "%s is not a UsdRenderVar" % vpath)
                        continue
                    var = UsdRender.Var(vprim)
                    source = var.GetSourceNameAttr().Get() or ""
                    if source not in AOVS:
                        self.problem(vpath, "sourceName", "unknown AOV '%s'; dropped" % source)
                        continue
                    kind = var.GetSourceTypeAttr().Get() or "raw"
                    if kind != "raw":
                        self.problem(vpath, "sourceType", "'%s' is not supported; '%s' is read "
                                     "as Tide's own AOV of that name" % (kind, source))
                    if source in vars_:
                        self.problem(vpath, "sourceName", "'%s' is already in %s; written once"
                                     % (source, ppath))
                        continue
                    vars_.append(source)
                    # the sample format (halves for a half type); unauthored, Tide's own
                    dtype = var.GetDataTypeAttr()
                    if dtype.HasAuthoredValue():
                        tok = str(dtype.Get() or "")
                        if Sdf.ValueTypeNames.Find(tok):
                            types[source] = tok
                        else:
                            self.problem(vpath, "dataType", "'%s' is not a value type; written "
                                         "as 32-bit float" % tok)
                if not vars_:
                    if prod.GetOrderedVarsRel().GetForwardedTargets():
                        self.problem(ppath, "orderedVars", "no AOV left to write; colour is "
                                     "written instead")
                    vars_ = ["color"]
                products.append((str(ppath), name, vars_, types))
        if not products:
            products.append(("", "", ["color"], {}))
        self.products = []
        for ppath, name, vars_, types in products:
            bound = []
            for source in vars_:
                buf = BUFFER_ROOT + "/" + source.replace(":", "_")
                if buf not in self._desired:
                    b = _PrimState("bprim", "renderBuffer", "/")
                    b.set("dimensions", _ints([w, h]))
                    b.set("format", ("token", AOVS[source]))
                    if self.options.files_only and source != "color":
                        b.set("tide:publish", ("bool", False))
                    self._desired[buf] = b
                bound.append((source, buf))
            self.products.append(Product(ppath, name, bound, types))
        if len(self.products) == len(products_):
            self.renders = [[self.products[i] for i in g] for g in self._render_groups]
        else:   # no valid product: the default one
            self.renders = [list(self.products)]

    # -- gprims ---------------------------------------------------------------------------
    def _prim_id(self, path):
        """The `primId` of delegate prim `path`: a hash of the path (24 bits, exact in the
        AOV's floats), so that a prim keeps its id across edits, fresh loads and the frames of
        a sequence whatever else comes and goes. Of two paths on one id (one chance in 2^24
        per pair; about 3 % that any two of a thousand prims meet), the first seen keeps it and
        the other takes the next free one."""
        known = self._prim_ids.get(path)
        if known is not None:
            return known
        h = 0x811C9DC5
        for b in str(path).encode("utf-8"):
            h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
        i = (h ^ (h >> 24)) & 0xFFFFFF
        while i in self._prim_id_owners:
            i = (i + 1) & 0xFFFFFF
        self._prim_id_owners[i] = path
        self._prim_ids[path] = i
        return i

    def _material_for(self, prim):
        api = UsdShade.MaterialBindingAPI(prim)
        # the settings' materialBindingPurposes in order; "" is the all-purpose binding (a
        # purpose's own resolution falls back to it, taken only where "" is listed)
        for purpose in self._binding_purposes:
            mat, rel = api.ComputeBoundMaterial(purpose or UsdShade.Tokens.allPurpose)
            if mat and (not purpose or _binding_purpose(rel) == purpose):
                return str(self._eval_material(mat.GetPrim()))
        direct = prim.GetRelationship("material:binding")
        if direct and direct.GetTargets():
            target = direct.GetTargets()[0]
            self.problem(prim.GetPath(), "material:binding",
                         "bound material %s does not exist; using the default material" % target)
        return ""

    def _gprim_state(self, prim, dpath, source, transform_fn, motion_prims):
        type_name = GPRIMS[prim.GetTypeName()]
        st = _PrimState("rprim", type_name, source)
        st.set("transform", None, self._xform_samples(transform_fn, motion_prims))
        st.set("visibility", ("token", "inherited"))
        st.set("purpose", ("token", str(UsdGeom.Imageable(prim).ComputePurpose())))
        ds = prim.GetAttribute("doubleSided").Get()
        st.set("doubleSided", ("bool", bool(ds)))
        st.set("material", ("path", self._material_for(prim)))
        st.set("primId", ("int", self._prim_id(dpath)))
        ok = getattr(self, "_eval_" + type_name.lower())(prim, st)
        if ok is False:
            return None
        self._tide_attrs(prim, st)
        # Tide's applied API schemas (TideBubbleAPI has no attribute of its own to show it)
        tide_apis = [str(a) for a in prim.GetAppliedSchemas() if str(a).startswith("Tide")]
        if tide_apis:
            st.set("apiSchemas", ("paths", tuple(tide_apis)))
        if "accelerations" in st.values:
            # how many keys follow the curved path (UsdGeomMotionAPI, inherited)
            count = UsdGeom.MotionAPI(prim).ComputeNonlinearSampleCount(Usd.TimeCode(self.frame))
            st.set("motion:nonlinearSampleCount", ("int", int(count)))
        if self._blur != 1.0:
            # rates over the scaled window: velocities times s, accelerations times s squared
            for name, power in (("velocities", 1), ("accelerations", 2)):
                if name in st.values:
                    kind, tsize, data = st.values[name][0][1]
                    rate = np.frombuffer(data, dtype=np.float32) * np.float32(self._blur ** power)
                    st.set(name, (kind, tsize, rate.tobytes()))
        return st

    def _eval_gprim(self, prim, dpath, source):
        with self._blurred(prim):
            st = self._gprim_state(prim, dpath, source, self._world(prim), [prim])
            if st is not None:
                if _skinnable(prim, st):
                    self._skin(prim, st)
                self._desired[dpath] = st

    def _posed_apart(self, prim):
        """Whether an instance proxy is a gprim that a skeleton poses (each instance its own)."""
        return prim.GetTypeName() in ("Mesh", "Points", "BasisCurves") and \
            self._skinning.target(prim) is not None

    def _skin(self, prim, st, relative_to=None):
        """A mesh, points or basis curves bound to a Skeleton (UsdSkel) render posed, as
        UsdSkelImaging draws them: their points deformed by the skeleton's animation (blend
        shapes, then skinning; a mesh's normals too, which UsdSkelImaging drops), with samples
        over the shutter like authored point samples, and placed by the Skeleton's
        local-to-world transform, since skinned points are in the skeleton's space (relative to
        the prim `relative_to` for a point instancer's prototype, whose instances then place
        the one pose). When the pose cannot be computed (reported), the gprim keeps its authored
        points and transform."""
        target = self._skinning.target(prim)
        if target is None:
            return
        self._skel_sources.update(target.sources)
        # the binding's primvars (joint indices and weights, geomBindTransform) are inputs of
        # the skinning, not data to shade with
        for name in [n for n in st.primvars if n.startswith("skel:")]:
            del st.primvars[name]
        offsets = [0.0]
        if self._moving:
            offsets = self._shutter_offsets(target.time_samples(self._window()))
            if not self._held:
                offsets = target.turning_offsets(offsets, self._time)
        posed = target.compute([self._time(o) for o in offsets])
        if posed is None:
            return
        pts = [p for p, _ in posed]
        if len(pts) > 1 and any(not np.array_equal(p, pts[0]) for p in pts):
            st.set("points", None, [(o, _floats(p, 3)) for o, p in zip(offsets, pts)])
        else:
            st.set("points", _floats(pts[0], 3))
        space = self._world(target.space)
        if relative_to is not None:
            outer = self._world(relative_to)
            st.set("transform", None, self._xform_samples(
                lambda t: space(t) * outer(t).GetInverse(), [target.space, relative_to]))
        else:
            st.set("transform", None, self._xform_samples(space, [target.space]))
        # A mesh's authored normals follow the points (blend-shape normalOffsets, then the
        # joints), at the frame; where they cannot, the core computes normals from the posed
        # points. A ribbon's (curves with normals) stay as authored, and say so. Authored
        # velocities and accelerations describe the unposed points, so they go; the posed
        # samples carry the motion.
        if st.type == "basisCurves" and "normals" in st.primvars:
            self.problem(prim.GetPath(), "normals", "a skinned ribbon keeps its authored normals "
                         "(they are not skinned)")
        elif st.primvars.get("normals", (None, None, 0))[2] == 3:
            interp, data, _, indices = st.primvars.pop("normals")
            normals = np.frombuffer(data, dtype=np.float32).reshape(-1, 3)
            if indices is not None:
                normals = normals[np.frombuffer(indices, dtype=np.int32)]
            fvi = UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get(self._time(0)) or []
            n_points = len(UsdGeom.PointBased(prim).GetPointsAttr().Get(self._time(0)) or [])
            skinned = target.compute_normals(normals, interp, fvi, n_points, self._time(0))
            if skinned is not None:
                st.primvars["normals"] = (interp, skinned.tobytes(), 3, None)
        else:
            st.primvars.pop("normals", None)
        st.values.pop("velocities", None)
        st.values.pop("accelerations", None)

    def _tide_attrs(self, prim, st):
        for attr in prim.GetAttributes():
            name = attr.GetName()
            if name in UNTAGGED_UNLESS_AUTHORED and not attr.HasAuthoredValue():
                # an applied TideCausticsAPI's fallback `false` is no explicit `false`: a caster
                # or emitter role not authored leaves the object or light untagged
                continue
            if name.startswith("tide:"):
                why = _mistyped(prim, attr)
                if why:
                    self.problem(prim.GetPath(), name, "%s; its default is used" % why)
                    continue
                v = convert(attr.Get(self._time(0)), attr.GetTypeName())
                if v is not None:
                    allowed = ALLOWED_TOKENS.get(name)
                    if allowed and v[1] not in allowed:
                        self.problem(prim.GetPath(), name, "unknown token '%s'; using '%s'"
                                     % (v[1], allowed[0]))
                        v = ("token", allowed[0])
                    st.set(name, v)
        for rel in prim.GetRelationships():
            name = rel.GetName()
            if name.startswith("tide:"):
                targets = rel.GetForwardedTargets()
                st.set(name, ("path", str(targets[0]) if targets else ""))

    def _attr(self, prim, name, fallback=None, offset=0.0):
        attr = prim.GetAttribute(name)
        v = attr.Get(self._time(offset)) if attr else None
        return self._checked(prim.GetPath(), name, v, fallback)

    def _checked(self, where, name, value, fallback):
        """`value`, or `fallback` when it is None, or (with a problem) when it is not of the
        fallback's kind (an attribute authored with another type than its schema's)."""
        if value is None:
            return fallback
        if fallback is not None and not _kind_ok(value, fallback):
            self.problem(where, name, "%r is not %s; using %r"
                         % (value, _kind_name(fallback), fallback))
            return fallback
        return value

    def _culprit(self, prim):
        """(path, attribute, why) of the first value on `prim` or an ancestor whose authored
        type is not its schema's, or of an xform op USD skips (see _placement); None if none:
        what a failed read of `prim` is blamed on."""
        p = prim
        while p and not p.IsPseudoRoot():
            skipped = _placement(p, self._time(0))[2] if UsdGeom.Xformable(p) else []
            if skipped:
                return (p.GetPath(),) + skipped[0]
            for a in p.GetAuthoredAttributes():
                why = _mistyped(p, a)
                if why:
                    return p.GetPath(), a.GetName(), why
            p = p.GetParent()
        return None

    def _token(self, prim, st, name, fallback):
        v = str(self._attr(prim, name, fallback))
        allowed = ALLOWED_TOKENS.get(name)
        if allowed and v not in allowed:
            self.problem(prim.GetPath(), name, "unknown token '%s'; using '%s'" % (v, fallback))
            v = fallback
        st.set(name, ("token", v))
        return v

    def _primvar_values(self, owner, pv):
        """A primvar's values as float32 rows (n x tuple) and its indices (int32, or None);
        None when it holds no numbers, or when an index is out of range (reported on
        `owner`)."""
        value = pv.Get(self._time(0))
        if value is None:
            return None
        if isinstance(value, (Gf.Quatf, Gf.Quatd, Gf.Quath)):
            value = [value]
        arr = np.array(_quat_rows(value)) if _is_quat_array(value) else np.asarray(value)
        if arr.dtype == object or arr.dtype.kind in "USO":
            return None
        if not pv.GetTypeName().isArray:
            # one value of its type (a color3f, a matrix4d): one row of all its components
            arr = arr.reshape(1, -1)
        rows = arr.astype(np.float32).reshape(-1, _tuple_size(arr))
        idx = None
        if pv.IsIndexed():
            idx = np.asarray(pv.GetIndices(self._time(0)), dtype=np.int32)
            if idx.size and (idx.min() < 0 or idx.max() >= len(rows)):
                self.problem(owner, "primvars:%s:indices" % pv.GetPrimvarName(),
                             "index out of range; primvar dropped")
                return None
        return rows, idx

    def _primvars(self, prim, st, skip=()):
        api = UsdGeom.PrimvarsAPI(prim)
        for pv in api.FindPrimvarsWithInheritance():
            if not pv.HasValue():
                continue
            name = pv.GetPrimvarName()
            if name in skip:
                continue
            why = _mistyped(prim, pv.GetAttr())
            if why:
                # a schema's primvar (a bubble's heights, a blobby's scales) of another type
                self.problem(prim.GetPath(), pv.GetAttr().GetName(), "%s; ignored" % why)
                continue
            got = self._primvar_values(prim.GetPath(), pv)
            if got is None:
                continue
            rows, idx = got
            st.primvars[name] = (str(pv.GetInterpolation()), np.ascontiguousarray(rows).tobytes(),
                                 rows.shape[1], None if idx is None else idx.tobytes())

    def _points_samples(self, prim, st, name="points"):
        """Points (and time samples of them within the shutter); False when unusable."""
        pts = self._attr(prim, name)
        if pts is None:
            self.problem(prim.GetPath(), name, "no %s; prim dropped" % name)
            return None
        arr = np.asarray(pts, dtype=np.float32).reshape(-1, 3)
        if not np.all(np.isfinite(arr)):
            self.problem(prim.GetPath(), name, "NaN or infinite values; prim dropped")
            return None
        samples = [(None, _floats(arr, 3))]
        if self._moving:
            attr = prim.GetAttribute(name)
            # samples outside the shutter still move the points across it (USD interpolates
            # between the samples around each time): sampled at its ends and at those within
            if attr.GetNumTimeSamples() > 1:
                offs = self._shutter_offsets(attr.GetTimeSamplesInInterval(self._window()))
                got = [np.asarray(attr.Get(self._time(o)), dtype=np.float32).reshape(-1, 3)
                       for o in offs]
                other = [(o, g) for o, g in zip(offs, got) if g.shape != arr.shape]
                if other:
                    vel = prim.GetAttribute("velocities")
                    then = "its samples are not used (its velocities move it)" \
                        if vel and vel.HasAuthoredValue() else "the prim renders static at frame 0"
                    self.problem(prim.GetPath(), name, "the time sample at frame offset %g has %d "
                                 "points, frame 0 has %d; the topology must not change over "
                                 "the shutter, so %s" % (other[0][0], len(other[0][1]), len(arr), then))
                elif not all(np.all(np.isfinite(g)) for g in got):
                    self.problem(prim.GetPath(), name, "NaN or infinite values in a time sample; "
                                 "the prim renders static at frame 0")
                elif any(not np.array_equal(g, got[0]) for g in got):
                    samples = [(o, _floats(g, 3)) for o, g in zip(offs, got)]
        st.set(name, None, samples)
        return arr

    def _eval_mesh(self, prim, st):
        arr = self._points_samples(prim, st)
        if arr is None:
            return False
        if prim.IsA(UsdGeom.TetMesh):
            return self._eval_tetmesh(prim, st, arr)
        if prim.IsA(UsdGeom.NurbsPatch):
            return self._eval_patch(prim, st, arr)
        mesh = UsdGeom.Mesh(prim)
        t = self._time(0)
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(t) or [], dtype=np.int64)
        idx = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(t) or [], dtype=np.int64)
        path = prim.GetPath()
        if counts.size and counts.min() < 3:
            self.problem(path, "faceVertexCounts", "a face has fewer than 3 vertices; prim dropped")
            return False
        if int(counts.sum()) != idx.size:
            self.problem(path, "faceVertexIndices", "%d indices for faces needing %d; prim dropped"
                         % (idx.size, int(counts.sum())))
            return False
        if idx.size and (idx.min() < 0 or idx.max() >= len(arr)):
            self.problem(path, "faceVertexIndices", "index out of range (0..%d); prim dropped"
                         % (len(arr) - 1))
            return False
        st.set("faceVertexCounts", _ints(counts))
        st.set("faceVertexIndices", _ints(idx))
        st.set("holeIndices", _ints(mesh.GetHoleIndicesAttr().Get(t) or []))
        self._token(prim, st, "orientation", "rightHanded")
        scheme = self._token(prim, st, "subdivisionScheme", "catmullClark")
        self._token(prim, st, "triangleSubdivisionRule", "catmullClark")
        # subdivision tags (used where `tide:subdivision:level`, or the refinement asked for
        # where it is not authored, refines the mesh)
        if self.options.refine_level:
            st.set("displayStyle:refineLevel", ("int", int(self.options.refine_level)))
        self._token(prim, st, "interpolateBoundary", "edgeAndCorner")
        self._token(prim, st, "faceVaryingLinearInterpolation", "cornersPlus1")
        for name, kind in (("creaseIndices", "i"), ("creaseLengths", "i"), ("cornerIndices", "i"),
                           ("creaseSharpnesses", "f"), ("cornerSharpnesses", "f")):
            v = self._attr(prim, name)
            if v is not None and len(v):
                st.set(name, _ints(np.asarray(v, dtype=np.int64)) if kind == "i"
                       else _floats(np.asarray(v, dtype=np.float32), 1))
        self._point_vectors(prim, st, len(arr))
        self._subsets(prim, st)
        self._primvars(prim, st)
        self._normals(mesh, st)
        self._mesh_light(prim, st)
        return True

    def _mesh_light(self, prim, st):
        """UsdLuxMeshLightAPI: the mesh emits (`meshLight` and the light's own attributes)."""
        if not prim.HasAPI(UsdLux.MeshLightAPI):
            return
        light = UsdLux.LightAPI(prim)
        st.set("meshLight", ("bool", True))
        for name, attr, fb in (("inputs:intensity", light.GetIntensityAttr(), 1.0),
                               ("inputs:exposure", light.GetExposureAttr(), 0.0),
                               ("inputs:colorTemperature", light.GetColorTemperatureAttr(), 6500.0)):
            st.set(name, ("float", float(self._attr(prim, name, fb))))
        for name, attr in (("inputs:normalize", light.GetNormalizeAttr()),
                           ("inputs:enableColorTemperature", light.GetEnableColorTemperatureAttr())):
            v = attr.Get(self._time(0)) if attr else None
            st.set(name, ("bool", bool(v)))
        c = light.GetColorAttr().Get(self._time(0))
        st.set("inputs:color", _floats(list(c) if c is not None else [1.0, 1.0, 1.0], 3))
        self._token(prim, st, "light:materialSyncMode", "materialGlowTintsLight")
        _link_collections(light, st)

    def _point_vectors(self, prim, st, count):
        """`velocities` and `accelerations`, one per point (else reported and not sent)."""
        for name in ("velocities", "accelerations"):
            v = self._attr(prim, name)
            if v is not None and len(v):
                if len(v) != count:
                    self.problem(prim.GetPath(), name, "%d %s for %d points; ignored"
                                 % (len(v), name, count))
                    continue
                st.set(name, _floats(v, 3))

    def _subsets(self, prim, st):
        """materialBind GeomSubsets: their face indices and resolved material bindings."""
        subsets = UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(prim), UsdGeom.Tokens.face,
                                                "materialBind")
        paths = []
        for sub in subsets:
            sp = str(sub.GetPath())
            idx = np.asarray(sub.GetIndicesAttr().Get(self._time(0)) or [], dtype=np.int64)
            paths.append(sp)
            st.set(sp + ".indices", _ints(idx))
            st.set(sp + ".material", ("path", self._material_for(sub.GetPrim())))
        if paths:
            st.set("geomSubsets", ("paths", tuple(paths)))

    def _normals(self, pb, st):
        if "normals" in st.primvars:
            return
        n = pb.GetNormalsAttr().Get(self._time(0))
        if n is not None and len(n):
            st.primvars["normals"] = (str(pb.GetNormalsInterpolation()),
                                      np.ascontiguousarray(np.asarray(n, dtype=np.float32)
                                                           .reshape(-1)).tobytes(), 3, None)

    def _eval_points(self, prim, st):
        arr = self._points_samples(prim, st)
        if arr is None:
            return False
        pts = UsdGeom.Points(prim)
        t = self._time(0)
        self._primvars(prim, st)
        if "widths" not in st.primvars:
            w = pts.GetWidthsAttr().Get(t)
            if w is not None and len(w):
                wa = np.asarray(w, dtype=np.float32)
                interp = str(pts.GetWidthsInterpolation())
                if len(wa) == 1:
                    interp = "constant"
                elif len(wa) != len(arr):
                    self.problem(prim.GetPath(), "widths", "%d widths for %d points; using 1"
                                 % (len(wa), len(arr)))
                    wa, interp = np.ones(1, np.float32), "constant"
                st.primvars["widths"] = (interp, wa.tobytes(), 1, None)
            else:
                st.primvars["widths"] = ("constant", np.ones(1, np.float32).tobytes(), 1, None)
        self._point_vectors(prim, st, len(arr))
        self._normals(pts, st)
        return True

    def _eval_basiscurves(self, prim, st):
        arr = self._points_samples(prim, st)
        if arr is None:
            return False
        if prim.IsA(UsdGeom.NurbsCurves):
            return self._eval_nurbs(prim, st, arr)
        if prim.IsA(UsdGeom.HermiteCurves):
            return self._eval_hermite(prim, st, arr)
        curves = UsdGeom.BasisCurves(prim)
        t = self._time(0)
        counts = self._curve_counts(prim, len(arr))
        if counts is None:
            return False
        st.set("curveVertexCounts", _ints(counts))
        for name, fb in (("type", "cubic"), ("basis", "bezier"), ("wrap", "nonperiodic")):
            self._token(prim, st, name, fb)
        self._primvars(prim, st)
        if "widths" not in st.primvars:
            w = curves.GetWidthsAttr().Get(t)
            if w is not None and len(w):
                # the delegate checks the count against the interpolation
                st.primvars["widths"] = (str(curves.GetWidthsInterpolation()),
                                         np.asarray(w, dtype=np.float32).tobytes(), 1, None)
        self._point_vectors(prim, st, len(arr))
        self._normals(curves, st)
        return True

    def _curve_counts(self, prim, n_points, least=0):
        """A Curves prim's `curveVertexCounts`, or None (reported: the prim is dropped) when they
        do not add up to its points or a curve has fewer than `least` vertices."""
        counts = np.asarray(UsdGeom.Curves(prim).GetCurveVertexCountsAttr().Get(self._time(0))
                            or [], dtype=np.int64)
        if counts.size and counts.min() < least or int(counts.sum()) != n_points:
            self.problem(prim.GetPath(), "curveVertexCounts", "the counts add up to %d vertices, "
                         "the curves have %d points%s; prim dropped"
                         % (int(counts.sum()), n_points,
                            " (%d or more each)" % least if least else ""))
            return None
        return counts

    def _eval_nurbs(self, prim, st, arr):
        """NurbsCurves, evaluated exactly (`nurbs`), go to the delegate as linear curves through
        their samples, with widths, normals, velocities and point samples carried along."""
        curves = UsdGeom.NurbsCurves(prim)
        t = self._time(0)
        path = prim.GetPath()
        counts = self._curve_counts(prim, len(arr))
        if counts is None:
            return False
        orders = np.asarray(curves.GetOrderAttr().Get(t) or [], dtype=np.int64)
        knots = np.asarray(curves.GetKnotsAttr().Get(t) or [], dtype=np.float64)
        if len(orders) != len(counts):
            self.problem(path, "order", "%d orders for %d curves; prim dropped"
                         % (len(orders), len(counts)))
            return False
        if knots.size != int((counts + orders).sum()):
            self.problem(path, "knots", "%d knots; the curves need %d; prim dropped"
                         % (knots.size, int((counts + orders).sum())))
            return False
        weights = curves.GetPointWeightsAttr().Get(t)
        if weights is not None and len(weights) == 0:
            weights = None
        if weights is not None and len(weights) != len(arr):
            self.problem(path, "pointWeights", "%d weights for %d points; ignored"
                         % (len(weights), len(arr)))
            weights = None
        ranges = curves.GetRangesAttr().Get(t)
        if ranges is not None and len(ranges) == 0:
            ranges = None
        if ranges is not None and len(ranges) != len(counts):
            self.problem(path, "ranges", "%d ranges for %d curves; ignored"
                         % (len(ranges), len(counts)))
            ranges = None
        cmap = nurbs.CurvesMap(counts, orders, knots, weights, ranges,
                               lambda attr, msg: self.problem(path, attr, msg))
        if not cmap.blocks:
            return False
        self._send_converted_curves(prim, st, len(arr), len(counts), cmap.counts(), "linear",
                                    cmap.per_vertex, lambda v: (cmap.per_curve(v), "vertex"))
        return True

    def _map_points(self, st, fn):
        """Replaces every sample of the sent `points` by fn(points, offset) (the sample's frame
        offset, None for the value at the frame)."""
        st.set("points", None, [(o, _floats(fn(np.frombuffer(v[2], dtype=np.float32)
                                                 .reshape(-1, 3).astype(np.float64), o), 3))
                                for o, v in st.values["points"]])

    def _send_converted_curves(self, prim, st, n_points, n_curves, counts, kind, vertex_map,
                               uniform_map, data_map=None, points_map=None):
        """Sends curves another curve type was converted to (nonperiodic, `kind` linear or cubic
        bezier; `n_curves` source curves, `counts` vertices per converted curve): `vertex_map`
        carries per-point rows onto the new vertices, `points_map` (else `vertex_map`) the
        points' samples (points, frame offset), `data_map` (else `vertex_map`) per-point widths,
        normals, velocities and accelerations, `uniform_map` per-curve rows to (rows,
        interpolation)."""
        data_map = data_map or vertex_map
        curves = UsdGeom.Curves(prim)
        path = prim.GetPath()
        t = self._time(0)
        self._map_points(st, points_map or (lambda p, o: vertex_map(p)))
        st.set("curveVertexCounts", _ints(counts))
        st.set("type", ("token", kind))
        st.set("basis", ("token", "bezier"))
        st.set("wrap", ("token", "nonperiodic"))
        self._primvars(prim, st)
        for name, attr, interp in (
                ("widths", curves.GetWidthsAttr(), curves.GetWidthsInterpolation()),
                ("normals", prim.GetAttribute("normals"), UsdGeom.PointBased(prim)
                 .GetNormalsInterpolation())):
            pv = st.primvars.pop(name, None)
            v, interp = (attr.Get(t) if attr else None), str(interp)
            if pv is not None:      # primvars:widths / primvars:normals win, as USD says
                interp, data, tsize, idx = pv
                v = np.frombuffer(data, dtype=np.float32).reshape(-1, tsize)
                if idx is not None:
                    v = v[np.frombuffer(idx, dtype=np.int32)]
            if v is None or len(v) == 0:
                continue
            v = np.asarray(v, dtype=np.float64).reshape(len(v), -1)
            if len(v) == 1 or interp == "constant":
                out, interp = v[:1], "constant"
            elif interp in ("vertex", "varying") and len(v) == n_points:
                out, interp = data_map(v), "vertex"
            elif interp == "uniform" and len(v) == n_curves:
                out, interp = uniform_map(v)
            else:
                self.problem(path, name, "%d %s values with %s interpolation do not fit the "
                             "curves; ignored" % (len(v), name, interp))
                continue
            st.primvars[name] = (interp, np.ascontiguousarray(out, dtype=np.float32)
                                 .reshape(-1).tobytes(), v.shape[1], None)
        for name in ("velocities", "accelerations"):
            v = self._attr(prim, name)
            if v is not None and len(v):
                if len(v) != n_points:
                    self.problem(path, name, "%d %s for %d points; ignored"
                                 % (len(v), name, n_points))
                    continue
                st.set(name, _floats(data_map(np.asarray(v, dtype=np.float64)), 3))

    def _eval_hermite(self, prim, st, arr):
        """HermiteCurves go to the delegate as cubic bezier curves, the same curves: each
        segment's inner vertices are P0 + T0/3 and P1 - T1/3. Widths and normals per vertex
        are interpolated at the thirds. Under motion blur, tangents with time samples are read
        at every offset the points are sampled at (the points then at the tangents' offsets
        too), so that the curves bend as they move."""
        curves = UsdGeom.HermiteCurves(prim)
        t = self._time(0)
        path = prim.GetPath()
        counts = self._curve_counts(prim, len(arr), least=2)
        if counts is None:
            return False
        tangents = np.asarray(curves.GetTangentsAttr().Get(t) or [], dtype=np.float64)
        if tangents.shape != (len(arr), 3) or not np.all(np.isfinite(tangents)):
            self.problem(path, "tangents", "%d finite tangents needed, one per point; prim "
                         "dropped" % len(arr))
            return False
        # per output vertex: (point a, point b, weight of b, tangent index, tangent factor)
        rows = []
        first = 0
        for c in counts:
            for i in range(first, first + c - 1):
                rows += [(i, i, 0.0, i, 0.0), (i, i + 1, 1 / 3, i, 1 / 3),
                         (i, i + 1, 2 / 3, i + 1, -1 / 3)]
            rows.append((first + c - 1, first + c - 1, 0.0, first + c - 1, 0.0))
            first += c
        a, b, wb, ti, tf = (np.array(x) for x in zip(*rows))

        def blend(v):       # per-point data at the thirds (linear between the points)
            v = np.asarray(v, dtype=np.float64).reshape(len(arr), -1)
            return v[a] * (1 - wb)[:, None] + v[b] * wb[:, None]

        base = np.where(tf < 0, b, a)

        def place(p, tan=tangents):  # the bezier vertices: the points, their tangents' thirds between
            return p[base] + tan[ti] * tf[:, None]

        tangents_at = self._hermite_tangent_samples(prim, st, arr, tangents)
        self._send_converted_curves(prim, st, len(arr), len(counts), 3 * (counts - 1) + 1, "cubic",
                                    place, lambda v: (v, "uniform"), data_map=blend,
                                    points_map=lambda p, o: place(p, tangents_at.get(o, tangents)))
        return True

    def _hermite_tangent_samples(self, prim, st, arr, tangents):
        """{frame offset: tangents} of a moving HermiteCurves prim whose tangents have time
        samples, sampled as points are (the shutter's ends and the samples within), with the
        sent points resampled at the union of their offsets; {} otherwise. A sample of another
        count is reported and the tangents at the frame used throughout."""
        attr = UsdGeom.HermiteCurves(prim).GetTangentsAttr()
        if not (self._moving and attr.GetNumTimeSamples() > 1):
            return {}
        offsets = self._shutter_offsets(attr.GetTimeSamplesInInterval(self._window()))
        got = {o: np.asarray(attr.Get(self._time(o)) or [], dtype=np.float64) for o in offsets}
        bad = [o for o, v in got.items() if v.shape != tangents.shape or not np.all(np.isfinite(v))]
        if bad:
            self.problem(prim.GetPath(), "tangents", "the time sample at frame offset %g does not "
                         "hold %d finite tangents; the tangents at the frame are used over the "
                         "shutter" % (bad[0], len(tangents)))
            return {}
        sent = dict(st.values["points"])
        if None in sent and prim.GetAttribute("velocities").HasAuthoredValue():
            # velocities move the points: the shape is held at the frame's tangents
            self.problem(prim.GetPath(), "tangents", "animated tangents with velocities moving "
                         "the points: the tangents at the frame are used over the shutter")
            return {}
        points = prim.GetAttribute("points")
        samples = []
        for o in sorted(set(k for k in sent if k is not None) | set(offsets)):
            if o in sent:
                samples.append((o, sent[o]))
            else:
                p = np.asarray(points.Get(self._time(o)), dtype=np.float32).reshape(-1, 3)
                samples.append((o, _floats(p if p.shape == arr.shape and np.all(np.isfinite(p)) else arr, 3)))
        st.set("points", None, samples)
        return got

    def _eval_tetmesh(self, prim, st, arr):
        """A TetMesh renders its surface: the faces `surfaceFaceVertexIndices` names, else the
        tetrahedra's faces no two tetrahedra share (UsdGeomTetMesh.ComputeSurfaceFaces)."""
        tm = UsdGeom.TetMesh(prim)
        t = self._time(0)
        tets = np.asarray(tm.GetTetVertexIndicesAttr().Get(t) or [], dtype=np.int64).reshape(-1, 4)
        if tets.size and (tets.min() < 0 or tets.max() >= len(arr)):
            self.problem(prim.GetPath(), "tetVertexIndices", "index out of range (0..%d); prim "
                         "dropped" % (len(arr) - 1))
            return False
        faces = tm.GetSurfaceFaceVertexIndicesAttr().Get(t)
        if not faces:
            faces = UsdGeom.TetMesh.ComputeSurfaceFaces(tm, t)
        faces = np.asarray(faces or [], dtype=np.int64).reshape(-1, 3)
        if faces.size and (faces.min() < 0 or faces.max() >= len(arr)):
            self.problem(prim.GetPath(), "surfaceFaceVertexIndices", "index out of range; prim "
                         "dropped")
            return False
        st.set("faceVertexCounts", _ints(np.full(len(faces), 3)))
        st.set("faceVertexIndices", _ints(faces.reshape(-1)))
        self._token(prim, st, "orientation", "rightHanded")
        st.set("subdivisionScheme", ("token", "none"))
        self._point_vectors(prim, st, len(arr))
        self._primvars(prim, st)
        return True

    def _eval_patch(self, prim, st, arr):
        """A NurbsPatch renders its surface, evaluated exactly (`nurbs.patch_matrix`) on a grid
        of quads with smooth normals; trim curves are not applied (reported)."""
        patch = UsdGeom.NurbsPatch(prim)
        t = self._time(0)
        path = prim.GetPath()

        def get(name, fallback=None):
            v = prim.GetAttribute(name).Get(t)
            return fallback if v is None else v

        nu, nv = int(get("uVertexCount", 0)), int(get("vVertexCount", 0))
        if nu * nv != len(arr):
            self.problem(path, "uVertexCount", "%d x %d vertices for %d points; prim dropped"
                         % (nu, nv, len(arr)))
            return False
        rng = lambda n: None if get(n) is None else tuple(get(n))  # noqa: E731
        weights = get("pointWeights")
        if weights is not None and len(weights) == 0:
            weights = None
        try:
            m, (su, sv), (cut_u, cut_v) = nurbs.patch_matrix(
                (int(get("uOrder", 0)), get("uKnots", []), rng("uRange"), nu),
                (int(get("vOrder", 0)), get("vKnots", []), rng("vRange"), nv), weights,
                note=lambda attr, msg: self.problem(path, attr, msg))
        except nurbs.NurbsError as e:
            self.problem(path, e.attribute, "%s; prim dropped" % e)
            return False
        except ValueError as e:
            self.problem(path, "pointWeights", "%s; prim dropped" % e)
            return False
        if get("trimCurve:counts") is not None and len(get("trimCurve:counts")):
            self.problem(path, "trimCurve:counts", "trim curves are not applied; the whole "
                         "patch renders")
        self._map_points(st, lambda p, o: m @ p)
        # no quad across a break (a knot repeated `order` times: the surface jumps there)
        quads = []
        for j in range(sv - 1):
            for i in range(su - 1):
                if i in cut_u or j in cut_v:
                    continue
                k = j * su + i
                quads.append((k, k + 1, k + 1 + su, k + su))
        st.set("faceVertexCounts", _ints(np.full(len(quads), 4)))
        st.set("faceVertexIndices", _ints(np.asarray(quads).reshape(-1)))
        self._token(prim, st, "orientation", "rightHanded")
        st.set("subdivisionScheme", ("token", "none"))
        # smooth normals from the grid's u and v derivatives (du x dv faces the front)
        g = (m @ arr.astype(np.float64)).reshape(sv, su, 3)
        n = np.cross(_piecewise_gradient(g, 1, cut_u), _piecewise_gradient(g, 0, cut_v))
        if str(get("orientation", "rightHanded")) == "leftHanded":
            n = -n
        n = _collapsed_edge_normals(n, np.abs(g).max())
        st.primvars["normals"] = ("vertex", np.ascontiguousarray(n, dtype=np.float32)
                                  .reshape(-1).tobytes(), 3, None)
        for name in ("velocities", "accelerations"):
            v = self._attr(prim, name)
            if v is not None and len(v) == len(arr):
                st.set(name, _floats(m @ np.asarray(v, dtype=np.float64), 3))
        # primvars: constant ones as they are, vertex and varying ones carried onto the grid
        # as the points are
        self._primvars(prim, st, skip=("normals",))
        for name, (interp, data, tsize, idx) in list(st.primvars.items()):
            if name == "normals" or interp == "constant":
                continue
            rows = np.frombuffer(data, dtype=np.float32).reshape(-1, tsize)
            if idx is not None:
                rows = rows[np.frombuffer(idx, dtype=np.int32)]
            if interp in ("vertex", "varying") and len(rows) == nu * nv:
                st.primvars[name] = ("vertex", np.ascontiguousarray(m @ rows, dtype=np.float32)
                                     .reshape(-1).tobytes(), tsize, None)
            else:
                del st.primvars[name]
                self.problem(path, "primvars:" + name, "%s primvar of %d values on a %d x %d "
                             "NurbsPatch is not carried onto its surface; ignored"
                             % (interp, len(rows), nu, nv))
        return True

    def _eval_implicit(self, prim, st):
        attrs = IMPLICIT_ATTRS_BY_SCHEMA.get(str(prim.GetTypeName()), IMPLICIT_ATTRS[st.type])
        for name, fb in attrs.items():
            if name == "axis":
                self._token(prim, st, name, fb)
            else:
                v = float(self._attr(prim, name, fb))
                if not math.isfinite(v) or v < 0:
                    self.problem(prim.GetPath(), name, "%s = %r is invalid; using %r"
                                 % (name, v, fb))
                    v = fb
                st.set(name, ("float", v))
        self._primvars(prim, st)
        return True

    _eval_sphere = _eval_cube = _eval_cylinder = _eval_cone = _eval_capsule = _eval_plane = \
        _eval_implicit

    def _eval_tideocean(self, prim, st):
        defn = prim.GetPrimDefinition()
        for name in ("windSpeed", "windDirection", "spectrum", "patchSize", "resolution",
                     "choppiness", "seed", "extent", "depth"):
            attr = prim.GetAttribute(name)
            st.set(name, convert(attr.Get(self._time(0)), attr.GetTypeName()) if attr else None)
        if "spectrum" in st.values and st.values["spectrum"][0][1][1] not in \
                ("piersonMoskowitz", "jonswap"):
            self.problem(prim.GetPath(), "spectrum", "unknown token '%s'; using "
                         "'piersonMoskowitz'" % st.values["spectrum"][0][1][1])
            st.set("spectrum", ("token", "piersonMoskowitz"))
        time_attr = prim.GetAttribute("time")
        if time_attr and time_attr.HasAuthoredValue():
            st.set("time", ("float", float(time_attr.Get(self._time(0)))))
        else:
            st.set("time", ("float", self.frame / self.stage.GetTimeCodesPerSecond()))
        del defn
        self._primvars(prim, st)
        return True

    def _eval_volume(self, prim, st):
        vol = UsdVol.Volume(prim)
        for name, fpath in sorted(vol.GetFieldPaths().items()):
            fprim = self.stage.GetPrimAtPath(fpath)
            if not (fprim and fprim.IsA(UsdVol.OpenVDBAsset)):
                self.problem(prim.GetPath(), "field:%s" % name, "%s is not an OpenVDB asset"
                             % fpath)
                continue
            field = UsdVol.OpenVDBAsset(fprim)
            self._depend(fpath, prim.GetPath())
            asset = field.GetFilePathAttr().Get(self._time(0))
            resolved = asset.resolvedPath if asset else ""
            if not resolved:
                self.problem(fpath, "filePath", "cannot find VDB file '%s'; field dropped"
                             % (asset.path if asset else ""))
                continue
            field_name = str(field.GetFieldNameAttr().Get() or name)
            index_attr = field.GetFieldIndexAttr()
            index = int(index_attr.Get()) if index_attr and index_attr.HasAuthoredValue() else 0
            st.set("field:%s" % name, ("asset", resolved))
            st.set("field:%s:fieldName" % name, ("token", field_name))
            st.set("field:%s:fieldIndex" % name, ("int", index))
            # the field prim's own placement relative to the volume (identity when the field
            # sits under the volume with no transform of its own)
            cache = self._placements(self._time(0))
            rel = cache.GetLocalToWorldTransform(fprim) * cache.GetLocalToWorldTransform(prim).GetInverse()
            st.set("field:%s:transform" % name, _matrix(rel))
            if name == "density":
                self._load_vdb(resolved, field_name, index)
        return True

    def _depend(self, source, dependent):
        """Records that prim `dependent` was read from prim `source` too: an edit to `source`
        reads `dependent` again."""
        self._depends.setdefault(Sdf.Path(source), set()).add(Sdf.Path(dependent))

    def _load_vdb(self, path, field_name, index, reload=False):
        """Has the module read a grid, once per (file, field, index) and again when `reload`
        (its file changed); a failure reaches the delegate, which reports it on the volumes
        that read the grid. Each grid read is remembered with its file's modification time."""
        if not hasattr(self, "_vdbs"):
            self._vdbs = {}
        key = (path, field_name, index)
        if key in self._vdbs and not reload:
            return
        self._vdbs[key] = _mtime(path)
        try:
            if reload:
                self.delegate.load_vdb(path, field_name, index, reload=True)
            else:
                self.delegate.load_vdb(path, field_name, index)
        except Exception as e:  # the module refused the call itself
            self.problem(path, "field:density", "cannot read grid '%s': %s" % (field_name, e))

    # -- instancing -----------------------------------------------------------------------
    def _collect_instanced(self, prim):
        """A gprim inside a native instance: grouped by prototype prim (and material)."""
        root = prim.GetParent()
        while root and not root.IsInstance():
            root = root.GetParent()
        self._instance_sources.add(root.GetPath())
        proto = prim.GetPrimInPrototype().GetPath()
        material = self._material_for(prim)
        # instances inheriting different sets of constant primvars from outside the prototype
        # are told apart (UsdImaging's instancers split so): each group's instances all hold a
        # value of each name it sends per instance
        key = (str(proto), material, _outside_primvar_names(prim, root.GetPath()))
        grp = self._groups.setdefault(key, {"prim": prim, "root": root, "members": []})
        grp["members"].append(root)
        if self._recording:
            inherited = self._inherited_values(root, key[2])
            if inherited is None or not self._static(root):
                # values inherited from outside that cannot be read, or a root moving within
                # its instance: each instance read on its own
                self._unshared()
            else:
                m = self._still_world(root)
                values = {n: [v] for n, v in inherited.items()}
                for rec in self._recording:
                    rec["entries"].append((key, [str(root.GetPath())], m[None], values))

    def _inherited_values(self, prim, names):
        """{name: (the path of the prim holding the value `prim` inherits, the value as one
        flat row)} of the constant primvars `names`; None if one of them holds no numbers."""
        out = {}
        for name in names:
            q = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)
            owner = q.GetAttr().GetPrim().GetPath() if q else None
            got = self._primvar_values(owner, q) if q else None
            if got is None:
                return None
            out[name] = (str(owner), (got[0] if got[1] is None else got[0][got[1]]).reshape(-1))
        return out

    def _unshared(self):
        """Notes that what the instances being recorded hold is read for each on its own (a
        light, camera, skinned gprim, point instancer, inherited values that cannot be read):
        their likes are walked each, not placed from the first."""
        for rec in self._recording:
            rec["plain"] = False

    def _instance_shortcut(self, prim, it):
        """Reads native instance `prim` (a stage-level instance or one nested in another's
        prototype) from the first instance like it, where that one's gprims are grouped by
        prototype and nothing of it is sent on its own: the first's members of each group are
        placed under `prim` by its transform (their transforms relative to the first's, times
        `prim`'s), at paths with `prim`'s in place of the first's, in the order a walk of
        `prim` would add them, each with the constant primvars it inherits from `prim` or above
        (`prim`'s) or from inside it (the first's member's). Instances are alike when they have
        the same prototype, purpose, and the same material bindings, motion attributes and
        primvar names authored on them and above (content, not paths), none of them a
        collection binding, and do not move over the shutter. True when `prim` was read here
        (the walk then skips its children)."""
        key = self._instance_key(prim) if SHARE_INSTANCES else None
        if key is None:
            return False
        rep = self._reps.get(key)
        if rep is False:
            return False
        if rep is None:
            it.PruneChildren()
            # the first: walked as usual, what it adds to the groups recorded
            rec = {"entries": [], "plain": True}
            problems = len(self._pending)
            self._recording.append(rec)
            try:
                pred = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
                for child in prim.GetFilteredChildren(pred):
                    self._walk(child)
            finally:
                self._recording.pop()
            plain = rec["plain"] and len(self._pending) == problems
            self._reps[key] = self._relative(prim, rec["entries"]) if plain else False
            return True
        # what the members inherit from this instance or above, in place of the first's
        own = self._inherited_values(prim, sorted({n for gkey, _, _, _ in rep for n in gkey[2]}))
        if own is None:
            return False
        it.PruneChildren()
        world = self._still_world(prim)
        base = str(prim.GetPath())
        for gkey, suffixes, rel, kept in rep:
            paths = [base + s for s in suffixes]
            mats = rel @ world
            values = {n: [own[n] if v is None else (base + v[0], v[1]) for v in vs] for n, vs in kept.items()}
            self._groups[gkey]["members"].append((paths, mats, values))
            for rec in self._recording:
                rec["entries"].append((gkey, paths, mats, values))
        return True

    def _relative(self, anchor, entries):
        """The members instance `anchor` added to each group (`entries`: (group, innermost
        root paths, their world matrices, {primvar: what each inherits from outside its
        innermost instance, as (the path holding it, the value)})), relative to it: [(group,
        path suffixes, matrices relative to the anchor, {primvar: (the path holding it
        relative to the anchor, the value) where a member inherits it from inside the anchor,
        None where from the anchor or above})], each group's members in the order added."""
        world = self._still_world(anchor)
        inverse = np.linalg.inv(world)
        base = str(anchor.GetPath())
        inside = base + "/"
        by_group = {}
        for gkey, paths, mats, values in entries:
            g = by_group.setdefault(gkey, ([], [], {n: [] for n in values}))
            g[0].extend(p[len(base):] for p in paths)
            g[1].append(mats)
            for n, vs in values.items():
                g[2][n].extend((v[0][len(base):], v[1]) if v[0].startswith(inside) else None for v in vs)
        return [(gkey, suffixes, np.concatenate(mats) @ inverse, kept)
                for gkey, (suffixes, mats, kept) in by_group.items()]

    def _still_world(self, prim):
        """The world matrix (4 x 4, row vectors) of a prim that holds still over the shutter,
        from one transform cache for the sync."""
        if self._xforms is None:
            self._xforms = self._placements(self._time(0))
        return np.asarray(_mat_key(self._xforms.GetLocalToWorldTransform(prim))).reshape(4, 4)

    def _instance_key(self, prim):
        """What makes native instance `prim` alike others (see _instance_shortcut); None when
        it is to be walked on its own."""
        proto = prim.GetPrototype()
        if not proto or not self._static(prim):
            return None
        sig = self._outer_signature(prim)
        if sig is None:
            return None
        return (str(proto.GetPath()), str(UsdGeom.Imageable(prim).ComputePurpose()), sig)

    def _outer_signature(self, prim):
        """The material bindings (targets, strength), motion attributes and the names of the
        primvars authored on `prim` and its ancestors, as content; None if one of them authors
        a collection binding (its effect depends on where an instance lies)."""
        path = str(prim.GetPath())
        if path in self._signatures:
            return self._signatures[path]
        parent = prim.GetParent()
        sig = () if not parent or parent.IsPseudoRoot() else self._outer_signature(parent)
        if sig is not None:
            own = []
            for rel in prim.GetAuthoredRelationships():
                name = rel.GetName()
                if name.startswith("material:binding:collection"):
                    sig = None
                    break
                if name.startswith("material:binding"):
                    own.append((name, tuple(str(t) for t in rel.GetTargets()),
                                str(rel.GetMetadata("bindMaterialAs") or "")))
            if sig is not None:
                for attr in prim.GetAuthoredAttributes():
                    name = attr.GetName()
                    if name.startswith("primvars:"):
                        # which primvars, not their values: each instance's are read apart
                        own.append((name, "primvar"))
                    elif name.startswith("motion:"):
                        own.append((name, repr(attr.Get(self._time(0)))))
            if sig is not None and own:
                sig = sig + (tuple(sorted(own)),)
        self._signatures[path] = sig
        return sig

    def _static(self, prim):
        """Whether `prim`'s transform (its own and its ancestors') holds still over the
        shutter."""
        if not self._moving:
            return True
        interval = self._window()
        x = UsdGeom.Xformable(prim)
        while x:
            if _op_times(x, interval):
                return False
            parent = x.GetPrim().GetParent()
            x = UsdGeom.Xformable(parent) if parent else None
        return True

    def _emit_instance_groups(self):
        per_proto = {}
        for (proto, material, names), grp in sorted(self._groups.items()):
            n = per_proto.get(proto, 0)
            per_proto[proto] = n + 1
            dpath = proto if n == 0 else "%s_m%d" % (proto, n)
            prim, root = grp["prim"], grp["root"]
            with self._blurred(prim):
                st = self._instance_group(prim, root, dpath, material, names, grp["members"])
            if st is not None:
                self._desired[dpath] = st

    def _instance_group(self, prim, root, dpath, material, names, members):
        """The state of a prototype's gprim drawn at every instance root of `members` (each an
        instance root prim, or a block (root paths, their world matrices, {primvar: (path
        holding it, value) of each}) of instances placed from another like them, which stand
        still), which inherit the constant primvars `names` from outside the prototype."""
        roots = [m for m in members if not isinstance(m, tuple)]
        def rel(t):
            cache = self._placements(t)
            return cache.GetLocalToWorldTransform(prim) * \
                cache.GetLocalToWorldTransform(root).GetInverse()

        st = self._gprim_state(prim, dpath, "/", rel, [prim])
        if st is None:
            return None
        st.set("material", ("path", material))
        # the path each instance stands for in light-link collections: its proxy's
        inner = prim.GetPath().MakeRelativePath(root.GetPath())
        tail = "/" + str(inner)
        paths = []
        for m in members:
            if isinstance(m, tuple):
                paths.extend(p + tail for p in m[0])
            else:
                paths.append(str(m.GetPath().AppendPath(inner)))
        st.set("instancePaths", ("paths", tuple(paths)))
        self._inherited_by_instances(st, names, members)
        # each instance root's world matrix over the shutter (motion of the instances
        # themselves; the prototype's own motion is in `transform`)
        offsets = sorted({o for r in roots for o in self._motion_offsets([r])}) or [0.0]
        worlds = []
        for o in offsets:
            cache = self._placements(self._time(o))
            parts = [m[1].reshape(-1, 16) if isinstance(m, tuple) else
                     np.asarray([_mat_key(cache.GetLocalToWorldTransform(m))], np.float64)
                     for m in members]
            worlds.append(np.ascontiguousarray(np.concatenate(parts), np.float64))
        if all(np.array_equal(w, worlds[0]) for w in worlds):
            st.set("instanceTransforms", ("doubles", 16, worlds[0].tobytes()))
        else:
            st.set("instanceTransforms", None,
                   [(o, ("doubles", 16, w.tobytes())) for o, w in zip(offsets, worlds)])
        return st

    def _shown_in_prototype(self, g, proto, t):
        """Whether prim `g` of prototype `proto` is drawn, as UsdImaging takes it: visibility and
        purpose from `g` up to the prototype's root only (what lies above the root, such as an
        invisible scope that keeps the prototypes from drawing in place, does not apply; the
        instancer's own do)."""
        p, purpose = g, None
        while p:
            img = UsdGeom.Imageable(p)
            if img:
                if img.GetVisibilityAttr().Get(t) == UsdGeom.Tokens.invisible:
                    return False
                a = img.GetPurposeAttr()
                if purpose is None and a.HasAuthoredValue():
                    purpose = a.Get()
            if p.GetPath() == proto.GetPath():
                break
            p = p.GetParent()
        return purpose is None or self._purpose_included(purpose)

    def _eval_instancer(self, prim, outer=None):
        """A PointInstancer's prototypes, each gprim sent once with the world matrices of its
        instances. `outer`, for an instancer inside another's prototype: (offsets, a function
        of an offset giving the world matrices of the instances placing that prototype, the
        prototype's parent, their per-instance primvars {name: (rows, tuple)}); each of those
        instances then places all of this one's, which take its primvars where they have none
        of that name. The instances move over the window of the instancer's blurScale."""
        with self._blurred(prim):
            self._place_instances(prim, outer)

    def _place_instances(self, prim, outer):
        """_eval_instancer's work, within the instancer's blurScale."""
        inst = UsdGeom.PointInstancer(prim)
        path = prim.GetPath()
        self._instance_sources.add(path)
        t = self._time(0)
        protos = inst.GetPrototypesRel().GetForwardedTargets()
        # prototypes may lie outside the instancer: an edit to one places its instances anew
        self._instance_sources.update(protos)
        idx = np.asarray(inst.GetProtoIndicesAttr().Get(t) or [], dtype=np.int64)
        pos = inst.GetPositionsAttr().Get(t)
        n = idx.size
        if pos is None or len(pos) != n:
            self.problem(path, "positions", "%d positions for %d protoIndices; instancer dropped"
                         % (0 if pos is None else len(pos), n))
            return
        if n and (idx.min() < 0 or idx.max() >= len(protos)):
            self.problem(path, "protoIndices", "index out of range (%d prototypes); "
                         "instancer dropped" % len(protos))
            return
        for name in ("orientations", "orientationsf", "scales"):
            a = prim.GetAttribute(name)
            v = a.Get(t) if a else None
            if v is not None and len(v) and len(v) != n:
                self.problem(path, name, "%d %s for %d instances; instancer dropped"
                             % (len(v), name, n))
                return
        mask = list(inst.ComputeMaskAtTime(t) or [])
        keep = np.asarray(mask, dtype=bool) if mask else np.ones(n, dtype=bool)
        # per instance world matrices at each motion offset: (offsets, [n x 4 x 4] per offset)
        offsets, mats_at, place = self._instancer_motion(prim, inst, n)
        copies, inherited = 1, {}
        if outer is not None:
            offsets, mats_at, place, copies = self._nested(prim, offsets, place, outer[:3])
            inherited = outer[3]
        per_instance = self._per_instance_primvars(prim, n)
        for k, ppath in enumerate(protos):
            proto = self.stage.GetPrimAtPath(ppath)
            sel = np.flatnonzero((idx == k) & keep)
            if not proto:
                self.problem(path, "prototypes", "prototype %s does not exist" % ppath)
                continue
            if not len(sel):
                continue
            # every copy of the instancer (one per outer instance) places the selection
            sel_all = (np.arange(copies)[:, None] * n + sel[None, :]).ravel()
            it_xf = [(o, np.ascontiguousarray(m[sel_all], dtype=np.float64))
                     for o, m in zip(offsets, mats_at)]
            # the per-instance primvars of the selection, in its order: this level's, then the
            # outer instances' (each repeated over the instances it places)
            rows = {name: (np.tile(data[sel], (copies, 1)), tsize)
                    for name, (data, tsize) in per_instance.items()}
            for name, (outer_rows, tsize) in inherited.items():
                rows.setdefault(name, (np.repeat(outer_rows, len(sel), axis=0), tsize))
            base = path.AppendChild("proto%d_%s" % (k, proto.GetName()))
            parent = proto.GetParent()
            # as UsdImaging walks prototypes: defined or not (a prototype under an `over`
            # is drawn), but active, loaded and not abstract
            pred = Usd.TraverseInstanceProxies(Usd.PrimIsActive & Usd.PrimIsLoaded &
                                               ~Usd.PrimIsAbstract)
            it = iter(Usd.PrimRange(proto, pred))
            for g in it:
                if g.IsA(UsdGeom.PointInstancer):
                    # a nested instancer: placed by each of this prototype's instances
                    if self._shown_in_prototype(g, proto, t):
                        self._eval_instancer(g, (offsets, lambda o, s=sel_all: place(o)[s], parent,
                                                 rows))
                    it.PruneChildren()
                    continue
                if g.GetTypeName() not in GPRIMS:
                    continue
                if not self._shown_in_prototype(g, proto, t):
                    continue
                relp = g.GetPath().MakeRelativePath(proto.GetPath())
                dpath = str(base if str(relp) == "." else base.AppendPath(relp))

                def rel(tc, g=g, parent=parent):
                    cache = self._placements(tc)
                    m = cache.GetLocalToWorldTransform(g)
                    if parent:
                        m = m * cache.GetLocalToWorldTransform(parent).GetInverse()
                    return m

                with self._blurred(g):
                    st = self._gprim_state(g, dpath, str(path), rel, [g])
                if st is None:
                    continue
                if _skinnable(g, st):
                    # one pose, its skeleton's, that every instance places
                    self._skin(g, st, relative_to=None if parent.IsPseudoRoot() else parent)
                for name, (data, tsize) in rows.items():
                    _set_instance_primvar(st, name, data, tsize)
                if len(it_xf) == 1:
                    st.set("instanceTransforms", ("doubles", 16, it_xf[0][1].tobytes()))
                else:
                    st.set("instanceTransforms", None,
                           [(o, ("doubles", 16, m.tobytes())) for o, m in it_xf])
                # each instance's index in the PointInstancer (the `instanceId` AOV)
                st.set("instanceIndices", _ints(sel_all % n))
                self._desired[dpath] = st

    def _per_instance_primvars(self, prim, n):
        """A PointInstancer's vertex and varying primvars (one value per instance): name ->
        (n x tuple float32 rows, tuple)."""
        out = {}
        for pv in UsdGeom.PrimvarsAPI(prim).GetPrimvarsWithValues():
            if pv.GetInterpolation() not in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
                continue
            name = str(pv.GetPrimvarName())
            got = self._primvar_values(prim.GetPath(), pv)
            if got is None:
                continue
            rows = got[0] if got[1] is None else got[0][got[1]]
            if len(rows) != n:
                self.problem(prim.GetPath(), "primvars:" + name, "%d values for %d instances; "
                             "ignored" % (len(rows), n))
                continue
            out[name] = (rows, rows.shape[1])
        return out

    def _inherited_by_instances(self, st, names, members):
        """The constant primvars `names` that native instances inherit from their instance
        prims (or above), where they differ between the instances: one value per instance.
        `members`: instance root prims, and blocks of placed instances carrying their values."""
        count = sum(len(m[0]) if isinstance(m, tuple) else 1 for m in members)
        if count < 2:
            return
        for name in names:
            vals = []
            for m in members:
                if isinstance(m, tuple):
                    vals.extend(v for _, v in m[2][name])
                    continue
                got = self._inherited_values(m, [name])
                if got is None:
                    break
                vals.append(got[name][1])
            if len(vals) != count or len({a.size for a in vals}) != 1 or \
                    all(np.array_equal(a, vals[0]) for a in vals):
                continue
            _set_instance_primvar(st, str(name), np.concatenate(vals), vals[0].size)

    def _instancer_motion(self, prim, inst, n):
        """Offsets (frames) and the instances' world matrices at each: one offset unless the
        instances move over the shutter (time-sampled positions / orientations / scales,
        velocities, angular velocities, accelerations, or the instancer's own transform).
        USD's ComputeInstanceTransformsAtTime extrapolates time-sampled positions with the
        velocities; positions with only a default value are extrapolated here the same way
        (p + v dt + a dt^2 / 2, the orientation turned by |w| dt about w after it; dt in
        seconds). Angular velocities and accelerations get 4 steps over the shutter, so a spin
        sweeps an arc (slerp between keys) and a parabola is followed within 1/16 of the
        chord's sag."""
        t = self._time(0)
        tcps = self.stage.GetTimeCodesPerSecond() or 24.0
        # the functions below may be called for a nested instancer, under another's scale
        blur, time = self._blur, self._time_fn()
        world_at = lambda o: self._world_at(prim, time(o))
        rates = {}
        pos_attr = inst.GetPositionsAttr()
        if pos_attr.GetNumTimeSamples() == 0:
            for name in ("velocities", "angularVelocities", "accelerations"):
                v = self._attr(prim, name)
                if v is None or not len(v):
                    continue
                if len(v) != n:
                    self.problem(prim.GetPath(), name, "%d %s for %d instances; ignored"
                                 % (len(v), name, n))
                    continue
                rates[name] = np.asarray(v, dtype=np.float64).reshape(-1, 3)
        base = inst.ComputeInstanceTransformsAtTime(
            t, t, UsdGeom.PointInstancer.ExcludeProtoXform, UsdGeom.PointInstancer.IgnoreMask)
        p0 = np.asarray(pos_attr.Get(t) or [], dtype=np.float64).reshape(-1, 3)
        # the matrices every extrapolated key starts from, as an array once
        base_arr = np.array(base, dtype=np.float64).reshape(-1, 4, 4) if rates else None

        def extrapolated(o):
            dt = blur * o / tcps
            out = base_arr.copy()
            p = p0.copy()
            if "velocities" in rates:
                p += rates["velocities"] * dt
            if "accelerations" in rates:
                p += rates["accelerations"] * 0.5 * dt * dt
            if "angularVelocities" in rates:
                # each instance turned about its own position (its translation is set below):
                # its 3 x 3 part times the turn, as a row-vector matrix
                out[:, :3, :3] = base_arr[:, :3, :3] @ _turns(rates["angularVelocities"], dt)
            out[:, 3, :3] = p
            return out

        def at(o):
            if rates:
                xf = extrapolated(o)
            else:
                xf = inst.ComputeInstanceTransformsAtTime(
                    time(o), t, UsdGeom.PointInstancer.ExcludeProtoXform,
                    UsdGeom.PointInstancer.IgnoreMask)
            if n and (xf is None or len(xf) != n):
                return None
            if not n:
                return np.zeros((0, 4, 4))
            return _times_matrix(np.asarray(xf, dtype=np.float64).reshape(-1, 4, 4),
                                 np.asarray(world_at(o), dtype=np.float64))

        still = [(0.0, at(0.0))]
        if not self._moving or not n:
            return [o for o, _ in still], [m for _, m in still], at
        lo, hi = self._shutter
        interval = self._window()
        times = []
        stepped = False
        for name in ("positions", "orientations", "orientationsf", "scales", "velocities",
                     "angularVelocities", "accelerations"):
            a = prim.GetAttribute(name)
            if not a or not a.HasAuthoredValue():
                continue
            times.extend(a.GetTimeSamplesInInterval(interval))
            if name in ("angularVelocities", "accelerations"):
                stepped = True
        offs = set(self._shutter_offsets(self._xform_times([prim]).union(times)))
        if stepped:
            # at least 4 steps (a spin's arc, a parabola within 1/16 of its sag), more where
            # motion:nonlinearSampleCount asks for more samples
            count = UsdGeom.MotionAPI(prim).ComputeNonlinearSampleCount(Usd.TimeCode(self.frame))
            steps = max(4, int(count) - 1)
            offs.update(lo + (hi - lo) * k / float(steps) for k in range(steps + 1))
        offs = sorted(offs)
        mats = [at(o) for o in offs]
        if any(m is None for m in mats):
            self.problem(prim.GetPath(), "positions", "the instances cannot be computed at every "
                         "time of the shutter (another instance count?); they do not move")
            return [o for o, _ in still], [m for _, m in still], lambda o: still[0][1]
        if all(np.array_equal(m, mats[0]) for m in mats):
            return [0.0], [mats[0]], at
        return offs, mats, at

    def _nested(self, prim, offsets, place, outer):
        """A nested instancer's placements: each of its instances (relative to the parent of
        the outer prototype it sits in) under each outer instance, outer-major. Returns
        (offsets, matrices per offset, the function giving them at an offset, copies)."""
        o_offsets, o_place, o_parent = outer
        copies = len(o_place(0.0))
        # the sample times of the levels that move (a still level's one sample is at 0)
        moving = [offs for offs in (offsets, o_offsets) if len(offs) > 1]
        if moving:
            offsets = sorted(set().union(*moving))

        time = self._time_fn()

        def nested(o):
            inner = place(o)
            if inner is None:
                return None
            cache = self._placements(time(o))
            q = np.asarray(cache.GetLocalToWorldTransform(o_parent), dtype=np.float64)
            rel = inner @ np.linalg.inv(q)
            return np.einsum("jab,ibc->ijac", rel, o_place(o)).reshape(-1, 4, 4)

        mats = [nested(o) for o in offsets]
        if any(m is None for m in mats):
            self.problem(prim.GetPath(), "positions", "the instances cannot be computed at every "
                         "time of the shutter (another instance count?); they do not move")
            offsets, mats = [0.0], [nested(0.0)]
        elif len(mats) > 1 and all(np.array_equal(m, mats[0]) for m in mats):
            offsets, mats = [0.0], [mats[0]]
        return offsets, mats, nested, copies

    # -- materials ------------------------------------------------------------------------
    def _eval_material(self, prim):
        path = str(prim.GetPath())
        if path in self._desired:
            return path
        mat = UsdShade.Material(prim)
        st = _PrimState("sprim", "material", path)
        queue = []
        for key, compute, output in (("surface", mat.ComputeSurfaceSource, mat.GetSurfaceOutput),
                                     ("volume", mat.ComputeVolumeSource, mat.GetVolumeOutput)):
            src = compute(_render_context(output))
            shader = src[0] if src else None
            if shader and shader.GetPrim().IsValid():
                st.set(key, ("path", str(shader.GetPath())))
                queue.append(shader)
            else:
                st.set(key, ("path", ""))
        # a UsdPreviewSurface displaces by its own input; a displacement terminal leading
        # elsewhere (a MaterialX displacement node) is passed on as the material's displacement
        src = mat.ComputeDisplacementSource(_render_context(mat.GetDisplacementOutput))
        shader = src[0] if src else None
        if shader and shader.GetPrim().IsValid() and shader.GetShaderId() != "UsdPreviewSurface":
            st.set("displacement", ("path", str(shader.GetPath())))
            queue.append(shader)
        # the material's own tide: attributes (TideWetAPI's, fallbacks included once applied)
        self._tide_attrs(prim, st)
        # a wetness mask: tide:wet:amount connected to a shader output of the material
        amount = prim.GetAttribute("tide:wet:amount")
        targets = amount.GetConnections() if amount else []
        if targets:
            up = targets[0]
            node = prim.GetStage().GetPrimAtPath(up.GetPrimPath())
            if node and node.IsA(UsdShade.Shader) and up.name.startswith("outputs:"):
                st.set("tide:wet:amount.connect", ("token", str(up)))
                queue.append(UsdShade.Shader(node))
            else:
                self.problem(path, "tide:wet:amount", "connected to '%s', which is not a shader "
                             "output; the authored amount is used" % up)
        done = set()
        while queue:
            shader = queue.pop(0)
            spath = str(shader.GetPath())
            if spath in done:
                continue
            done.add(spath)
            if not shader.GetPath().HasPrefix(prim.GetPath()):
                self._depend(shader.GetPath(), prim.GetPath())
            sid = shader.GetShaderId()
            if not sid:
                self.problem(spath, "info:id", "shader has no info:id; the material's default "
                             "is used")
                sid = ""
            elif not _known_shader(sid):
                self.problem(spath, "info:id", "unknown shader id '%s'; replaced by the default "
                             "material" % sid)
            st.set(spath + ".info:id", ("token", str(sid)))
            for inp in shader.GetInputs():
                name = inp.GetFullName()
                attrs = inp.GetValueProducingAttributes(False)
                if attrs and UsdShade.Output.IsOutput(attrs[0]):
                    up = attrs[0]
                    st.set(spath + "." + name + ".connect",
                           ("token", "%s.%s" % (up.GetPrim().GetPath(), up.GetName())))
                    queue.append(UsdShade.Shader(up.GetPrim()))
                    continue
                src_attr = attrs[0] if attrs else inp.GetAttr()
                if not src_attr.GetPrimPath().HasPrefix(prim.GetPath()):
                    self._depend(src_attr.GetPrimPath(), prim.GetPath())
                value = src_attr.Get(self._time(0))
                if value is None:
                    continue
                if isinstance(value, Sdf.AssetPath):
                    value = self._texture(shader, name, value)
                    # a file's colour space (USD metadata), as UsdImaging hands it on
                    if src_attr.HasColorSpace():
                        st.set("%s.inputs:colorSpace:%s" % (spath, inp.GetBaseName()),
                               ("token", str(src_attr.GetColorSpace())))
                st.set(spath + "." + name, convert(value, src_attr.GetTypeName()))
        self._desired[path] = st
        return path

    def _texture(self, shader, name, asset):
        resolved = asset.resolvedPath
        if not resolved:
            if asset.path:
                self.problem(shader.GetPath(), name, "cannot find texture '%s'; the input's "
                             "default is used" % asset.path)
            return Sdf.AssetPath("")
        if resolved not in self._textures_loaded():
            why = self._load_texture(resolved)
            if why is not None:
                self.problem(shader.GetPath(), name, "cannot read texture '%s' (%s); the input's "
                             "default is used" % (resolved, why))
                return Sdf.AssetPath("")
        return asset

    def _load_texture(self, path):
        """Has the module read texture file `path` (it hands the pixels to the delegate): None,
        or the reason it cannot. A file read is remembered with its modification time."""
        mtime = _mtime(path)
        try:
            self.delegate.load_texture(path)
        except OSError as e:
            return str(e) or "unreadable"
        self._textures_loaded()[path] = mtime
        return None

    def _textures_loaded(self):
        """Texture files read: path -> modification time when read."""
        if not hasattr(self, "_loaded"):
            self._loaded = {}
        return self._loaded

    def _reread_files(self):
        """Reads again the texture and VDB files changed on disk since they were read (the
        delegate then converts the materials and lights that use a texture anew, and places
        the volumes reading a grid with its new values); whether any was."""
        stale = [p for p, t in self._textures_loaded().items() if _mtime(p) != t]
        for path in stale:
            del self._loaded[path]
            why = self._load_texture(path)
            if why is not None:
                self.problem(path, "file", "cannot read texture '%s' again (%s); what uses it "
                             "falls back" % (path, why))
        grids = [k for k, t in getattr(self, "_vdbs", {}).items() if _mtime(k[0]) != t]
        for key in grids:
            self._load_vdb(*key, reload=True)
        return bool(stale or grids)

    # -- lights and cameras ---------------------------------------------------------------
    def _eval_light(self, prim):
        type_name = LIGHTS[prim.GetTypeName()]
        path = str(prim.GetPath())
        st = _PrimState("sprim", type_name, path)
        st.set("transform", None, self._xform_samples(self._world(prim), [prim]))
        st.set("visibility", ("token", "inherited"))
        attrs = dict(LIGHT_COMMON)
        attrs.update(LIGHT_SPECIFIC[type_name])
        vals = {}
        defn = prim.GetPrimDefinition()
        for name, fb in attrs.items():
            v = self._attr(prim, name, fb)
            # the schema's type (an attribute authored with another was replaced above)
            spec = defn.GetAttributeDefinition(name) if defn else None
            a = prim.GetAttribute(name)
            value_type = spec.GetTypeName() if spec else (a.GetTypeName() if a else None)
            if isinstance(v, Sdf.AssetPath):
                if v.path and not v.resolvedPath:
                    self.problem(path, name, "cannot find texture '%s'; the light uses its "
                                 "colour" % v.path)
                elif v.resolvedPath and v.resolvedPath not in self._textures_loaded():
                    why = self._load_texture(v.resolvedPath)
                    if why is not None:
                        self.problem(path, name, "cannot read texture '%s' (%s)" % (v.resolvedPath, why))
                        v = Sdf.AssetPath("")
                # the image's colour space (USD metadata on the attribute)
                if a and a.HasColorSpace():
                    st.set("colorSpace:" + name[len("inputs:"):], ("token", str(a.GetColorSpace())))
            if isinstance(fb, float):
                v = float(v)
                if not math.isfinite(v):
                    self.problem(path, name, "not a finite number; using %r" % fb)
                    v = fb
            vals[name] = v
            st.set(name, convert(v, value_type))
        for name in LIGHT_API_ATTRS:
            a = prim.GetAttribute(name)
            if a and a.HasValue():
                v = a.Get(self._time(0))
                if isinstance(v, Sdf.AssetPath):
                    v = Sdf.AssetPath(v.path, v.resolvedPath or v.path)
                st.set(name, convert(v, a.GetTypeName()))
        zero = None
        if type_name == "rectLight" and vals["inputs:width"] * vals["inputs:height"] <= 0:
            zero = "inputs:width" if vals["inputs:width"] <= 0 else "inputs:height"
        elif type_name == "diskLight" and vals["inputs:radius"] <= 0:
            zero = "inputs:radius"
        elif type_name == "sphereLight" and vals["inputs:radius"] <= 0 and \
                not vals["treatAsPoint"]:
            zero = "inputs:radius"
        elif type_name == "cylinderLight" and not vals["treatAsLine"] and \
                (vals["inputs:radius"] <= 0 or vals["inputs:length"] <= 0):
            zero = "inputs:radius" if vals["inputs:radius"] <= 0 else "inputs:length"
        if zero:
            self.problem(path, zero, "zero-area light; dropped")
            return
        if prim.GetTypeName() == "DomeLight_1":
            # DomeLight_1's poleAxis turns the dome alone (not its children), as Hydra's
            # domeOffset does: a Z pole maps the image's +Y to +Z and its centre to -Y
            pole = self._attr(prim, "poleAxis", "scene")
            if pole == "Z" or (pole == "scene" and UsdGeom.GetStageUpAxis(self.stage) == UsdGeom.Tokens.z):
                st.set("domeOffset", _matrix(Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90.0))))
        if type_name == "domeLight":
            # the portals that guide the dome's sampling (unauthored: those no dome names)
            rel = prim.GetRelationship("portals")
            if rel and rel.HasAuthoredTargets():
                st.set("portals", ("paths", tuple(str(t) for t in rel.GetForwardedTargets())))
        self._tide_attrs(prim, st)
        _link_collections(UsdLux.LightAPI(prim), st)
        self._desired[path] = st

    def _eval_portal(self, prim):
        """A PortalLight: a rectangle that guides domes' sampling; it emits nothing."""
        path = str(prim.GetPath())
        st = _PrimState("sprim", "portalLight", path)
        st.set("transform", None, self._xform_samples(self._world(prim), [prim]))
        st.set("visibility", ("token", "inherited"))
        for name in ("inputs:width", "inputs:height"):
            v = self._attr(prim, name, 1.0)
            if not math.isfinite(v):
                self.problem(path, name, "not a finite number; using 1")
                v = 1.0
            st.set(name, ("float", float(v)))
        self._desired[path] = st

    def _default_camera(self, spath):
        """A stage without a camera is seen as usdrecord sees it: through a default camera (a
        50 mm lens, USD's default apertures, no depth of field or motion blur) looking down -Z
        (down +Y on a Z-up stage) at the centre of the bounds of the stage's included
        purposes, backed off until the bounds' cross-section fits the horizontal field of view
        and their front face is in front of it; clipped so that all of it is seen. Framed on
        a full sync (the first, a new frame or render); an edit keeps the view."""
        if not self._partial or getattr(self, "_default_view", None) is None:
            self._default_view = self._frame_stage()
        xf, near, far, bounds = self._default_view
        st = _PrimState("sprim", "camera", "/")
        st.set("transform", _matrix(xf))
        for name, fb in CAMERA_ATTRS.items():
            st.set(name, _camera_value(name, (near, far) if name == "clippingRange" else fb, fb))
        self._desired[DEFAULT_CAMERA_PATH] = st
        self.problem(spath, "camera", "the stage has no camera; rendering a default view (%s) "
                     "that frames %s" % (DEFAULT_CAMERA_PATH, bounds))

    def _frame_stage(self):
        """(camera-to-world matrix, near, far, what it frames) of the default view (see
        _default_camera)."""
        purposes = [p for p in ("default", "render", "proxy", "guide") if p in self._purposes]
        cache = UsdGeom.BBoxCache(self._time(0), purposes, useExtentsHint=True)
        try:
            rng = cache.ComputeWorldBound(self.stage.GetPseudoRoot()).ComputeAlignedRange()
            lo, hi = rng.GetMin(), rng.GetMax()
            why = "empty" if rng.IsEmpty() else None if all(
                math.isfinite(v) for v in list(lo) + list(hi)) else "not finite"
        except Tf.ErrorException:  # a transform USD's Python binding refuses (see _placement)
            why = "unknown: USD cannot compute a prim's transform"
        bounds = "the stage's bounds"
        if why:
            bounds = "a cube of 2 units about the origin (the stage's bounds are %s)" % why
            lo, hi = Gf.Vec3d(-1, -1, -1), Gf.Vec3d(1, 1, 1)
        centre, size = (lo + hi) / 2.0, hi - lo
        z_up = UsdGeom.GetStageUpAxis(self.stage) == UsdGeom.Tokens.z
        # across the view (the focal plane) and along it
        across, along = (Gf.Vec2d(size[0], size[2]), size[1]) if z_up \
            else (Gf.Vec2d(size[0], size[1]), size[2])
        half_fov = math.atan(0.5 * CAMERA_ATTRS["horizontalAperture"] / CAMERA_ATTRS["focalLength"])
        front = 0.5 * across.GetLength() / math.tan(half_fov)
        if not front > 0.0:
            # bounds without breadth across the view (a point, a segment along it)
            front = max(along, 1.0)
        distance = front + 0.5 * along
        xf = Gf.Matrix4d(1.0)
        if z_up:
            xf.SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), 90.0))
            xf.SetTranslateOnly(centre + Gf.Vec3d(0, -distance, 0))
        else:
            xf.SetTranslate(centre + Gf.Vec3d(0, 0, distance))
        near = min(CAMERA_ATTRS["clippingRange"][0], 0.5 * front)
        far = max(CAMERA_ATTRS["clippingRange"][1], 2.0 * (distance + along))
        return xf, near, far, bounds

    def _eval_camera(self, prim):
        path = str(prim.GetPath())
        st = _PrimState("sprim", "camera", path)
        st.set("transform", None, self._xform_samples(self._world(prim), [prim]))
        for name, fb in CAMERA_ATTRS.items():
            v = self._attr(prim, name, fb)
            if name == "shutter:close" and self._instantaneous:
                v = self._attr(prim, "shutter:open", 0.0)
            if name == "exposure:fStop":
                # newer OpenUSD names it exposure:fNumber; an authored one of those wins
                a = prim.GetAttribute("exposure:fNumber")
                if a and a.HasAuthoredValue():
                    v = self._attr(prim, "exposure:fNumber", fb)
            if name in ("focalLength", "horizontalAperture", "verticalAperture"):
                if not (math.isfinite(v) and v > 0):
                    self.problem(path, name, "%s = %r must be positive; using %r" % (name, v, fb))
                    v = fb
            if name in ALLOWED_TOKENS and str(v) not in ALLOWED_TOKENS[name]:
                self.problem(path, name, "unknown token '%s'; using '%s'" % (v, fb))
                v = fb
            st.set(name, _camera_value(name, v, fb))
        planes = UsdGeom.Camera(prim).GetClippingPlanesAttr().Get(self._time(0))
        if planes:
            st.set("clippingPlanes", _floats([float(x) for p in planes for x in p], 4))
        rel = prim.GetRelationship("tide:medium")
        targets = rel.GetForwardedTargets() if rel else []
        if targets:
            mp = self.stage.GetPrimAtPath(targets[0])
            if mp and mp.IsA(UsdShade.Material):
                st.set("tide:medium", ("path", self._eval_material(mp)))
            else:
                self.problem(path, "tide:medium", "%s is not a material" % targets[0])
        self._desired[path] = st


def _binding_purpose(rel):
    """The material purpose of a binding relationship (material:binding:full, or a
    collection's material:binding:collection:full:NAME); "" for an all-purpose one."""
    parts = rel.GetName().split(":") if rel else []
    if parts[2:3] == ["collection"]:
        return parts[3] if len(parts) > 4 else ""
    return parts[2] if len(parts) > 2 else ""


def open_stage(path):
    """Opens a stage file; raises RuntimeError naming the file when it cannot be opened."""
    try:
        stage = Usd.Stage.Open(path)
    except Tf.ErrorException as e:
        raise RuntimeError("cannot open stage '%s': %s" % (path, str(e).strip())) from e
    if stage is None:
        raise RuntimeError("cannot open stage '%s'" % path)
    return stage


def stage_from_string(text):
    """A stage from .usda text (an anonymous layer)."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    if not layer.ImportFromString(text):
        raise RuntimeError("invalid .usda text")
    return Usd.Stage.Open(layer)
