#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine for Tide (idempotent; run as root): system packages,
# the Python venv (.venv with usd-core, pytest, numpy), the release build of the bridge and
# its Python module cpp-bridge/python/tide/_tide.so.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(build-essential pkg-config libopenimageio-dev libopencolorio-dev libopenvdb-dev libboost-dev python3-venv python3-dev)
missing=()
for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    if [ "$(id -u)" -ne 0 ]; then
        echo "setup.sh: missing packages ${missing[*]}: run as root" >&2
        exit 1
    fi
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
fi

PYTHON="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
    "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
.venv/bin/python -m pip install --quiet usd-core pytest numpy

# The module is built against the venv's interpreter headers (libpython is not linked).
PYTHON="$PWD/.venv/bin/python" cargo build --release -p tide-bridge --features python
install -m 755 target/release/libtide_bridge.so cpp-bridge/python/tide/_tide.so
.venv/bin/python -c "import sys; sys.path.insert(0, 'cpp-bridge/python'); import tide._tide; print('tide._tide ready')"
