#!/usr/bin/env bash
# Sets up Mitsuba 3 for regenerating the reference renders in tests/references/mitsuba/.
# CI never runs this. Usage (from anywhere):
#   source tests/mitsuba/setup.sh     # or: bash tests/mitsuba/setup.sh
# Creates tests/mitsuba/.venv with a pinned mitsuba + numpy, installs Debian's libllvm19 if
# missing (needed by the llvm_* variants) and exports DRJIT_LIBLLVM_PATH. Safe to run again.
set -euo pipefail
MITSUBA_VERSION="${MITSUBA_VERSION:-3.9.1}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV="$HERE/.venv"

if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c "import mitsuba, sys; sys.exit(mitsuba.__version__ != '$MITSUBA_VERSION')" 2>/dev/null; then
    "$VENV/bin/pip" install --quiet --upgrade pip
    "$VENV/bin/pip" install --quiet "mitsuba==$MITSUBA_VERSION" numpy
fi

find_llvm() {
    ls /usr/lib/llvm-19/lib/libLLVM.so.19.1 /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
       /usr/lib/*/libLLVM.so.19.1 2>/dev/null | head -n 1 || true
}
LIBLLVM="$(find_llvm)"
if [ -z "$LIBLLVM" ]; then
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq libllvm19 >/dev/null
    LIBLLVM="$(find_llvm)"
fi
export DRJIT_LIBLLVM_PATH="$LIBLLVM"
echo "mitsuba $MITSUBA_VERSION in $VENV"
echo "export DRJIT_LIBLLVM_PATH=$DRJIT_LIBLLVM_PATH"
