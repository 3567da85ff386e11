#!/usr/bin/env bash
# check_runtime.sh: builds the Hydra plugin (hdTide.so) against an OpenUSD build with imaging,
# links it with -Wl,--no-undefined, and runs check_runtime.cpp: Hydra's renderer-plugin registry
# loads the plugin from its plugInfo.json, and a render index, HdEngine and render pass render a
# sphere in a white dome, whose pixels are checked. Not part of CI (CI has no OpenUSD build):
#
#   cpp-bridge/hydra/check_runtime.sh OPENUSD_DIR
#
# OPENUSD_DIR is an OpenUSD install or CMake build tree with imaging (`include/pxr/pxr.h` and the
# `libusd_*.so` libraries somewhere under it; Python and GL are not needed: the `hd` and
# `usdShade` targets and their dependencies are enough, `usdImaging` and `usdShaders` as well for
# the stage comparison at the end). Such a tree, from OpenUSD's sources (apt packages cmake,
# ninja-build, libosd-dev, libtbb-dev; about 30 minutes on two cores at -O0):
#
#   cmake -G Ninja -S OPENUSD_SRC -B OPENUSD_DIR -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O0 -g0 -w" \
#       -DPXR_ENABLE_PYTHON_SUPPORT=OFF -DPXR_BUILD_IMAGING=ON -DPXR_BUILD_USD_IMAGING=ON \
#       -DPXR_ENABLE_GL_SUPPORT=OFF -DPXR_BUILD_GPU_SUPPORT=OFF -DPXR_BUILD_TESTS=OFF \
#       -DPXR_BUILD_EXAMPLES=OFF -DPXR_BUILD_TUTORIALS=OFF -DPXR_BUILD_USD_TOOLS=OFF \
#       -DPXR_ENABLE_MATERIALX_SUPPORT=OFF -DPXR_ENABLE_OPENVDB_SUPPORT=OFF -DPXR_ENABLE_PTEX_SUPPORT=OFF
#   ninja -C OPENUSD_DIR hd hdsi usdShade usdImaging usdSkelImaging usdVolImaging usdShaders
#
# Needs g++ (or $CXX), libtbb-dev, OpenImageIO and OpenColorIO dev packages, and a release build
# of the bridge (`cargo build --release -p tide-bridge`, for target/release/libtide_bridge.a and
# the cxx headers). Exit status: the compiler's or the check's.
marker=include/pxr/pxr.h what="OPENUSD_DIR   (an OpenUSD install or build tree with include/pxr/pxr.h)"
. "$(dirname "$0")/script_args.sh"
target=$repo/target/release
cxxbridge=$repo/target/cxxbridge
for f in "$target/libtide_bridge.a" "$cxxbridge/tide-bridge/src/lib.rs.h"; do
    [ -f "$f" ] || { echo "$0: $f missing: run 'cargo build --release -p tide-bridge'" >&2; exit 2; }
done
libdirs=$(find "$usd" -name 'libusd_*.so' -printf '%h\n' | sort -u)
[ -n "$libdirs" ] || { echo "$0: no libusd_*.so under $usd" >&2; exit 2; }
lflags=()
for d in $libdirs; do lflags+=(-L "$d" -Wl,-rpath,"$d"); done
usdlibs=(-lusd_hd -lusd_hf -lusd_cameraUtil -lusd_pxOsd -lusd_usdShade -lusd_usd -lusd_ndr -lusd_sdf -lusd_plug -lusd_trace -lusd_work -lusd_vt -lusd_gf -lusd_tf -lusd_arch -ltbb)

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
mkdir -p "$out/crate" "$out/plugin/hdTide/resources"
ln -s "$bridge" "$out/crate/tide-bridge"
common=(-std=c++17 -fPIC -O1 -Wno-deprecated -isystem "$usd/include" -isystem "$cxxbridge" -I "$out/crate" -I "$bridge/include")

echo "building hdTide.so against $usd"
"$cxx" "${common[@]}" -shared -Wl,--no-undefined -o "$out/plugin/hdTide.so" \
    "$here/rendererPlugin.cpp" "$here/hdTide.cpp" "$here/instancer.cpp" "$here/shaderDiscovery.cpp" \
    "$here/sceneIndexPlugin.cpp" "${lflags[@]}" -lusd_hdsi "${usdlibs[@]}" "$target/libtide_bridge.a" \
    $(pkg-config --libs OpenImageIO OpenColorIO Imath) -lopenvdb -ltbb -lpthread -ldl -lm || exit $?
sed -e 's|@PLUG_INFO_LIBRARY_PATH@|../hdTide.so|' -e 's|@PLUG_INFO_RESOURCE_PATH@|resources|' \
    -e 's|@PLUG_INFO_ROOT@|..|' "$here/plugInfo.json" > "$out/plugin/hdTide/resources/plugInfo.json"
mkdir -p "$out/plugin/hdTide/resources/shaders"
cp "$repo/schemas/shaders/TideWater.usda" "$repo/schemas/shaders/TideMedium.usda" "$out/plugin/hdTide/resources/shaders/"

echo "building check_runtime"
"$cxx" "${common[@]}" -o "$out/check_runtime" "$here/check_runtime.cpp" "${lflags[@]}" "${usdlibs[@]}" -lpthread || exit $?

echo "running check_runtime"
PXR_PLUGINPATH_NAME="$out/plugin/hdTide/resources" TIDE_OCIO_CONFIG="$bridge/ocio/config.ocio" "$out/check_runtime" || exit $?

# With OpenUSD's UsdImaging built too (libusd_usdImaging.so) and OPENUSD_SRC set to its source
# tree (for the schemas' resources, which a build tree only installs): the same stage rendered
# through UsdImaging and the plugin (once through UsdImaging's scene delegate, once through its
# scene indices), and through `tide render`'s usd-core reader, must agree (image means within 4
# combined standard errors + 1e-3).
if [ -z "${OPENUSD_SRC:-}" ] || [ -z "$(find "$usd" -name 'libusd_usdImaging.so' | head -n 1)" ]; then
    echo "(no UsdImaging build or OPENUSD_SRC: the stage comparison is skipped)"
    exit 0
fi
lay=$out/usd
mkdir -p "$lay/lib/usd"
for d in $libdirs; do ln -sf "$d"/libusd_*.so "$lay/lib/"; done
# plugin modules (usdShaders.so, ...) sit in lib/usd/ in an install
find "$usd/pxr" -name '*.so' -not -name 'libusd_*' -exec ln -sf {} "$lay/lib/usd/" \;
paths="$out/plugin/hdTide/resources:$repo/schemas"
while read -r info; do
    rel=${info#"$usd/"}
    name=$(basename "$(dirname "$info")")
    res=$lay/lib/usd/$name/resources
    mkdir -p "$res"
    cp "$info" "$res/plugInfo.json"
    for f in "$OPENUSD_SRC/$(dirname "$rel")"/*.usda; do [ -f "$f" ] && cp "$f" "$res/"; done
    [ -d "$OPENUSD_SRC/$(dirname "$rel")/shaders" ] && cp -r "$OPENUSD_SRC/$(dirname "$rel")/shaders" "$res/"
    paths="$paths:$res"
done < <(find "$usd/pxr" -name plugInfo.json -not -path '*codegenTemplates*')
echo "building usdImagingTide.so (Tide's UsdImaging adapters)"
mkdir -p "$out/plugin/usdImagingTide/resources"
"$cxx" "${common[@]}" -shared -Wl,--no-undefined -o "$out/plugin/usdImagingTide.so" "$here/usdImagingTide/adapters.cpp" \
    -L "$lay/lib" -Wl,-rpath,"$lay/lib" -lusd_usdImaging -lusd_usdGeom -lusd_usd -lusd_pcp -lusd_ar "${usdlibs[@]}" -lpthread || exit $?
sed -e 's|@PLUG_INFO_LIBRARY_PATH@|../usdImagingTide.so|' -e 's|@PLUG_INFO_RESOURCE_PATH@|resources|' \
    -e 's|@PLUG_INFO_ROOT@|..|' "$here/usdImagingTide/plugInfo.json" > "$out/plugin/usdImagingTide/resources/plugInfo.json"
paths="$paths:$out/plugin/usdImagingTide/resources"
echo "building check_runtime with UsdImaging"
"$cxx" "${common[@]}" -DTIDE_CHECK_USD_IMAGING -o "$out/check_stage" "$here/check_runtime.cpp" -L "$lay/lib" -Wl,-rpath,"$lay/lib" \
    -lusd_usdImaging -lusd_hdsi -lusd_usd -lusd_pcp -lusd_ar "${usdlibs[@]}" -lpthread || exit $?
# compare STAGE MODE...: renders STAGE through UsdImaging in each MODE and through tide render,
# and compares the image means; $complexity (usdview's and tide render's, default low) sets the
# viewer's refinement of both
compare() {
    local stage=$1 mode line levels=(low medium high veryhigh) refine=0
    shift
    for refine in 0 1 2 3; do [ "${levels[$refine]}" = "${complexity:-low}" ] && break; done
    local hydra=()
    for mode in "$@"; do
        line=$(TIDE_CHECK_REFINE=$refine PXR_PLUGINPATH_NAME="$paths" TIDE_OCIO_CONFIG="$bridge/ocio/config.ocio" "$out/check_stage" "$stage" /World/Cam 32 32 64 "$mode") || return $?
        hydra+=("$mode ${line#hydra }")
    done
    # $reference: the stage tide render reads instead (what $stage is after a live edit)
    "$repo/tide" render "${reference:-$stage}" -c "${complexity:-low}" -o "$out/core.exr" >/dev/null || return $?
    noise="${noise:-}" "$repo/.venv/bin/python" - "$out/core.exr" "${hydra[@]}" <<'PY'
import os
import sys
import numpy as np
import OpenEXR
import Imath
f = OpenEXR.InputFile(sys.argv[1])
dw = f.header()["dataWindow"]
w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
rgb = [np.frombuffer(f.channel(c, Imath.PixelType(Imath.PixelType.FLOAT)), dtype=np.float32).astype(np.float64) for c in "RGB"]
def noise(red):
    # as check_runtime prints it: horizontal neighbours' RMS difference over sqrt(2)
    img = red.reshape(h, w)
    return np.sqrt(np.mean((img[:, 1:] - img[:, :-1]) ** 2) / 2.0)
ok = True
for line in sys.argv[2:]:
    mode, *vals = line.split()
    hydra = [float(x) for x in vals]
    if os.environ.get("noise"):
        n, hn = noise(rgb[0]), hydra[6]
        print("red pixel noise: usd-core reader %.5f, UsdImaging (%s) %.5f" % (n, mode, hn))
        ok &= hn <= 2 * n + 1e-4
    for c in range(3):
        m, se = rgb[c].mean(), rgb[c].std() / np.sqrt(w * h)
        hm, hse = hydra[2 * c], hydra[2 * c + 1]
        tol = 4 * np.hypot(se, hse) + 1e-3
        print("channel %s: usd-core reader %.5f +- %.5f, UsdImaging (%s) %.5f +- %.5f"
              % ("RGB"[c], m, se, mode, hm, hse))
        ok &= abs(m - hm) <= tol
print("stage comparison: ok" if ok else "stage comparison: FAILED")
sys.exit(0 if ok else 1)
PY
}
# check STAGE WHAT MODE...: says what STAGE (in this folder) checks and through which paths,
# then compares it
check() {
    # (not named `paths`: compare reads the plugin search path of that name)
    local stage=$1 what=$2 via
    shift 2
    # TIDE_CHECK_ONLY=STAGE compares that stage alone
    [ -z "${TIDE_CHECK_ONLY:-}" ] || [ "$stage" = "$TIDE_CHECK_ONLY" ] || return 0
    case "$*" in
        "delegate sceneIndex") via="UsdImaging (scene delegate, then scene indices)" ;;
        delegate) via="UsdImaging's scene delegate" ;;
        sceneIndex) via="UsdImaging's scene indices" ;;
    esac
    echo "rendering $stage${what:+ ($what)} through $via and through tide render"
    compare "$here/$stage" "$@"
}
# check_linked_to_both STAGE WHAT: STAGE rendered, then its sun's lightLink collection given
# /World/Right too by a live edit through usd-core, through both paths; compared with tide render
# of the stage as edited
check_linked_to_both() {
    local stage=$1 what=$2 edited=$out/edited_$1
    sed 's|rel collection:lightLink:includes = </World/Left>|rel collection:lightLink:includes = [</World/Left>, </World/Right>]|' \
        "$here/$stage" > "$edited"
    grep -q '</World/Right>\]' "$edited" || { echo "$edited lacks its edit" >&2; return 1; }
    TIDE_CHECK_ADD_TARGET="/World/Sun.collection:lightLink:includes /World/Right" reference=$edited \
        check "$stage" "$what" delegate sceneIndex
}
# check_vdb STAGE WHAT: STAGE copied beside the sparse grid it reads (two balls of fog, written
# here by the bridge module's write_vdb), then compared as check does
check_vdb() {
    local stage=$1 what=$2
    [ -z "${TIDE_CHECK_ONLY:-}" ] || [ "$stage" = "$TIDE_CHECK_ONLY" ] || return 0
    cp "$here/$stage" "$out/$stage"
    PYTHONPATH="$repo/cpp-bridge/python" "$repo/.venv/bin/python" - "$out/check_cloud.vdb" <<'PY' || return $?
import sys
import numpy as np
from tide import _tide
# a ball of radius 30 voxels of 0.02 (density 1.5 at its centre, falling to 0 at its edge) at
# two places in one grid: index centres (-55, 0, 0) and (55, 0, 40)
r = 30
i = np.arange(2 * r + 1) - r
z, y, x = np.meshgrid(i, i, i, indexing="ij")
ball = np.clip(1.5 * (1.0 - (x * x + y * y + z * z) / float(r * r)), 0.0, None).astype(np.float32)
n = 2 * r + 1
entries = [("density", "float", (n, n, n), ball.tobytes(), 0.02, (0.0, 0.0, 0.0), (cx - r, -r, cz - r))
           for cx, cz in ((-55, 0), (55, 40))]
_tide.write_vdb(sys.argv[1], entries)
PY
    echo "rendering $stage ($what) through UsdImaging (scene delegate, then scene indices) and through tide render"
    compare "$out/$stage" delegate sceneIndex
}
# Tide's codeless schemas from schemas/; TideWater's and TideMedium's shader definitions come from
# the plugin's own discovery plugin
check check_stage.usda "" delegate sceneIndex || exit $?
check check_stage_tide.usda "Tide's own prims and attributes" delegate sceneIndex || exit $?
check check_stage_wet.usda "a material's TideWetAPI" delegate sceneIndex || exit $?
check check_stage_fx.usda "bubbles and blobbies" delegate sceneIndex || exit $?
check check_stage_motion.usda "the stage's frame rate, with the camera" sceneIndex || exit $?
check check_stage_spot.usda "UsdLuxShapingAPI: cone, focus, IES profile" delegate sceneIndex || exit $?
check check_stage_movinglight.usda "transform samples over the shutter: a light and a gprim" delegate sceneIndex || exit $?
check check_stage_curves.usda "BasisCurves: topology, widths, normals" delegate sceneIndex || exit $?
check check_stage_tapered.usda "Cylinder_1 and Capsule_1 end radii; one 8-bit texture read raw and auto" delegate sceneIndex || exit $?
# UsdSkelImaging (v24.08) has adapters for the scene delegate only: its scene indices drop skinned
# meshes ("Datasource support not yet added"), so only the scene delegate is compared
check check_stage_skel.usda "a skinned mesh: UsdSkelImaging's computations" delegate || exit $?
check check_stage_subdiv.usda "tide:subdivision:level, creases and corners" delegate sceneIndex || exit $?
complexity=veryhigh check check_stage_refine.usda "the viewer's refinement at complexity veryhigh" delegate sceneIndex || exit $?
check check_stage_fvar.usda "faceVaryingLinearInterpolation" delegate sceneIndex || exit $?
check check_stage_displace.usda "UsdPreviewSurface displacement" delegate sceneIndex || exit $?
check check_stage_primvars.usda "primvars read by a material, a varying displayColor" delegate sceneIndex || exit $?
check check_stage_subsets.usda "GeomSubsets bound to their own materials" delegate sceneIndex || exit $?
# Hydra syncs every purpose's rprims, the pass is executed with the tags geometry and render
TIDE_CHECK_TAGS="geometry,render,proxy,guide;geometry,render" \
    check check_stage_purposes.usda "the render pass's tags: purposes default and render of four" delegate sceneIndex || exit $?
# then, shown with its proxies, the proxy ball made a guide by a live edit: Hydra does not sync it
# (guides untracked), the plugin forwards its new tag at the commit and the pass leaves it out;
# the guide ball, never synced, stays out too (an rprim is hidden until its first sync: through
# the scene indices it was a unit ball at the origin, around the camera, before)
edited=$out/edited_purposes.usda
sed 's|uniform token purpose = "proxy"|uniform token purpose = "guide"|' "$here/check_stage_purposes.usda" > "$edited"
grep -q 'purpose = "proxy"' "$edited" && { echo "$edited keeps its proxy" >&2; exit 1; }
TIDE_CHECK_TAGS="geometry,render,proxy;geometry,render,proxy" TIDE_CHECK_SET_TOKEN="/World/Proxy.purpose guide" reference=$edited \
    check check_stage_purposes.usda "then its proxy made a guide by a live edit" delegate sceneIndex || exit $?
check check_stage_surface.usda "UsdPreviewSurface opacityThreshold, opacity, emissiveColor, metallic" delegate sceneIndex || exit $?
check check_stage_instances.usda "per-instance primvars of a PointInstancer and of native instances" delegate sceneIndex || exit $?
check check_stage_nested.usda "nested PointInstancers, the outer level's per-instance primvars" delegate sceneIndex || exit $?
check check_stage_lightlink.usda "a light linked to one of two walls" delegate sceneIndex || exit $?
# a live edit of the collection: through the scene indices it arrives by usdImagingTide's adapter
# (UsdImaging's CollectionAPI adapter, v24.08, misses collection properties)
check_linked_to_both check_stage_lightlink.usda "then linked to both walls by a live edit" || exit $?
# through the scene indices, HdTideInstanceCategoriesSceneIndex gives the instancer its instances'
# categories (HdsiLightLinkingSceneIndex, v24.08, gives instanced prims none)
check check_stage_lightlink_instances.usda "a light linked to one of two native instances" delegate sceneIndex || exit $?
# a live edit linking the sun to the second instance too: the instancer's categories are dirtied
# and re-read
check_linked_to_both check_stage_lightlink_instances.usda "then linked to both instances by a live edit" || exit $?
check_vdb check_stage_vdb.usda "a Volume's OpenVDB field: a sparse grid read as bricks" || exit $?
# UsdImaging's scene delegate (v24.08) passes no MeshLightAPI: only the scene indices are compared
check check_stage_meshlight.usda "UsdLuxMeshLightAPI" sceneIndex || exit $?
check check_stage_pole.usda "DomeLight_1's pole axis on a Z-up stage" delegate sceneIndex || exit $?
check check_stage_domespace.usda "a dome texture's colorSpace metadata" delegate sceneIndex || exit $?
check check_stage_lights.usda "a textured RectLight and a CylinderLight" delegate sceneIndex || exit $?
# portals change only the noise: compared there too
noise=1 check check_stage_portal.usda "UsdLuxPortalLight and a dome's portals" delegate sceneIndex || exit $?
# UsdImaging's scene delegate makes no renderSettings prims: only the scene indices are compared
check check_stage_product.usda "the active render settings and a product's own tide: settings" sceneIndex
