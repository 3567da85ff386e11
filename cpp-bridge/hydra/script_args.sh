# script_args.sh: sourced by check_headers.sh and check_runtime.sh. Checks their one argument, an
# OpenUSD directory that must hold "$marker", and sets usd (its absolute path), here (this
# folder), bridge (cpp-bridge/), repo (the repository root) and cxx (the compiler, $CXX or g++).
# Needs marker and what (the argument's description in the usage line) set before sourcing.
set -u
if [ $# -ne 1 ] || [ ! -f "$1/$marker" ]; then
    echo "usage: $0 $what" >&2
    exit 2
fi
usd=$(cd "$1" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
bridge=$(dirname "$here")
repo=$(dirname "$bridge")
cxx=${CXX:-g++}
