#!/usr/bin/env bash
# check_headers.sh: syntax and type check of the Hydra plugin (its six C++ sources, listed below)
# against the headers of an OpenUSD source checkout, without an OpenUSD build. scripts/test.sh
# runs it against OpenUSD v24.08's headers (scripts/fetch_openusd_headers.py); by hand:
#
#   cpp-bridge/hydra/check_headers.sh OPENUSD_SRC_DIR
#
# OPENUSD_SRC_DIR holds `pxr/` (headers are enough) and, if present, `cmake/defaults/Version.cmake`
# for the version numbers. The headers CMake would generate (`pxr/pxr.h` from `pxr/pxr.h.in`:
# namespaces on, Python support off) are written to a temporary directory. Needs g++ (or $CXX),
# libtbb-dev, and the cxx headers of a built tide-bridge (`target/cxxbridge`, from
# `cargo build -p tide-bridge`; $TIDE_CXXBRIDGE_DIR overrides). Warnings in Tide's code are errors;
# OpenUSD's headers are included as system headers, with -Wno-deprecated as OpenUSD's own build
# uses (its TfHashSet includes <ext/hash_set>). Exit status: the compiler's.
marker=pxr/pxr.h.in what="OPENUSD_SRC_DIR   (a directory with pxr/pxr.h.in)"
. "$(dirname "$0")/script_args.sh"
cxxbridge=${TIDE_CXXBRIDGE_DIR:-$repo/target/cxxbridge}
if [ ! -f "$cxxbridge/tide-bridge/src/lib.rs.h" ] || [ ! -f "$cxxbridge/rust/cxx.h" ]; then
    echo "$0: no cxx headers under $cxxbridge: run 'cargo build -p tide-bridge' or set TIDE_CXXBRIDGE_DIR" >&2
    exit 2
fi

major=0 minor=0 patch=0
version_cmake="$usd/cmake/defaults/Version.cmake"
if [ -f "$version_cmake" ]; then
    get() { sed -n "s/^set($1 \"\([0-9]*\)\").*/\1/p" "$version_cmake"; }
    major=$(get PXR_MAJOR_VERSION) minor=$(get PXR_MINOR_VERSION) patch=$(get PXR_PATCH_VERSION)
fi
version=$((major * 10000 + minor * 100 + patch))

gen=$(mktemp -d)
trap 'rm -rf "$gen"' EXIT
mkdir -p "$gen/pxr" "$gen/crate"
sed -e "s/@PXR_MAJOR_VERSION@/$major/" -e "s/@PXR_MINOR_VERSION@/$minor/" \
    -e "s/@PXR_PATCH_VERSION@/$patch/" -e "s/@PXR_VERSION@/$version/" \
    -e "s/@PXR_USE_NAMESPACES@/1/" -e "s/@PXR_EXTERNAL_NAMESPACE@/pxr/" \
    -e "s/@PXR_INTERNAL_NAMESPACE@/pxrInternal_v${major}_${minor}/" \
    -e "s/@PXR_PYTHON_SUPPORT_ENABLED@/0/" -e "s/@PXR_PREFER_SAFETY_OVER_SPEED@/1/" \
    "$usd/pxr/pxr.h.in" > "$gen/pxr/pxr.h"
if grep -q @ "$gen/pxr/pxr.h"; then
    echo "$0: pxr.h.in has placeholders this script does not fill:" >&2
    grep -n @ "$gen/pxr/pxr.h" >&2
    exit 2
fi
# cxx's generated lib.rs.h includes "tide-bridge/include/tide/...": the crate under its name.
ln -s "$bridge" "$gen/crate/tide-bridge"

# the checkout's commit, where $usd is the top of a git work tree of its own (not a folder
# inside another repository, such as this one's target/)
commit=""
if [ "$(git -C "$usd" rev-parse --show-toplevel 2>/dev/null)" = "$usd" ]; then commit=" ($(git -C "$usd" rev-parse HEAD))"; fi
echo "OpenUSD $major.$minor.$patch from $usd$commit; compiler: $($cxx --version | head -n 1)"
rc=0
for src in hdTide.cpp instancer.cpp rendererPlugin.cpp shaderDiscovery.cpp sceneIndexPlugin.cpp usdImagingTide/adapters.cpp; do
    echo "checking cpp-bridge/hydra/$src"
    "$cxx" -std=c++17 -fsyntax-only -Wall -Wextra -Wsuggest-override -Woverloaded-virtual -Wno-deprecated -Werror \
        -isystem "$gen" -isystem "$usd" -isystem "$cxxbridge" -I "$gen/crate" -I "$bridge/include" \
        "$here/$src" || rc=$?
done
[ $rc -eq 0 ] && echo "ok: no errors or warnings" || echo "failed (compiler exit status $rc)"
exit $rc
