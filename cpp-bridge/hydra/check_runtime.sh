#!/usr/bin/env bash
# check_runtime.sh: builds the Hydra plugin (hdTide.so) against an OpenUSD build with imaging,
# links it with -Wl,--no-undefined, and runs check_runtime.cpp: Hydra's renderer-plugin registry
# loads the plugin from its plugInfo.json, and a render index, HdEngine and render pass render a
# sphere in a white dome, whose pixels are checked. Not part of CI (CI has no OpenUSD build):
#
#   cpp-bridge/hydra/check_runtime.sh OPENUSD_DIR
#
# OPENUSD_DIR is an OpenUSD install or CMake build tree with imaging (`include/pxr/pxr.h` and the
# `libusd_*.so` libraries somewhere under it; Python, GL and usdImaging are not needed: the `hd`
# target and its dependencies are enough). Such a tree, from OpenUSD's sources (apt packages
# cmake, ninja-build, libosd-dev, libtbb-dev; about 15 minutes on two cores at -O0):
#
#   cmake -G Ninja -S OPENUSD_SRC -B OPENUSD_DIR -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O0 -g0 -w" \
#       -DPXR_ENABLE_PYTHON_SUPPORT=OFF -DPXR_BUILD_IMAGING=ON -DPXR_BUILD_USD_IMAGING=ON \
#       -DPXR_ENABLE_GL_SUPPORT=OFF -DPXR_BUILD_GPU_SUPPORT=OFF -DPXR_BUILD_TESTS=OFF \
#       -DPXR_BUILD_EXAMPLES=OFF -DPXR_BUILD_TUTORIALS=OFF -DPXR_BUILD_USD_TOOLS=OFF \
#       -DPXR_ENABLE_MATERIALX_SUPPORT=OFF -DPXR_ENABLE_OPENVDB_SUPPORT=OFF -DPXR_ENABLE_PTEX_SUPPORT=OFF
#   ninja -C OPENUSD_DIR hd Needs g++ (or $CXX), libtbb-dev, OpenImageIO and
# OpenColorIO dev packages, and a release build of the bridge (`cargo build --release -p
# tide-bridge`, for target/release/libtide_bridge.a and the cxx headers). Exit status: the
# compiler's or the check's.
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
usdlibs=(-lusd_hd -lusd_hf -lusd_cameraUtil -lusd_pxOsd -lusd_sdf -lusd_plug -lusd_trace -lusd_work -lusd_vt -lusd_gf -lusd_tf -lusd_arch -ltbb)

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
mkdir -p "$out/crate" "$out/plugin/hdTide/resources"
ln -s "$bridge" "$out/crate/tide-bridge"
common=(-std=c++17 -fPIC -O1 -Wno-deprecated -isystem "$usd/include" -isystem "$cxxbridge" -I "$out/crate" -I "$bridge/include")

echo "building hdTide.so against $usd"
"$cxx" "${common[@]}" -shared -Wl,--no-undefined -o "$out/plugin/hdTide.so" \
    "$here/rendererPlugin.cpp" "$here/hdTide.cpp" "$here/instancer.cpp" \
    "${lflags[@]}" "${usdlibs[@]}" "$target/libtide_bridge.a" \
    $(pkg-config --libs OpenImageIO OpenColorIO Imath) -lopenvdb -ltbb -lpthread -ldl -lm || exit $?
sed -e 's|@PLUG_INFO_LIBRARY_PATH@|../hdTide.so|' -e 's|@PLUG_INFO_RESOURCE_PATH@|resources|' \
    -e 's|@PLUG_INFO_ROOT@|..|' "$here/plugInfo.json" > "$out/plugin/hdTide/resources/plugInfo.json"

echo "building check_runtime"
"$cxx" "${common[@]}" -o "$out/check_runtime" "$here/check_runtime.cpp" "${lflags[@]}" "${usdlibs[@]}" -lpthread || exit $?

echo "running check_runtime"
PXR_PLUGINPATH_NAME="$out/plugin/hdTide/resources" TIDE_OCIO_CONFIG="$bridge/ocio/config.ocio" "$out/check_runtime"
