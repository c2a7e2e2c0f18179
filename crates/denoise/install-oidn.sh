#!/usr/bin/env bash
# Installs Intel Open Image Denoise 2.5.1 (libOpenImageDenoise and its CPU device) for torrey's
# `denoise` feature: the PyPI wheel `pyoidn` (which ships the library) into .oidn/ at the top of
# the work tree, where .cargo/config.toml points OIDN_DIR. Idempotent. Then build with
#   cargo build --release --features denoise
# Usage: bash crates/denoise/install-oidn.sh [PYTHON]   (default: python3; needs pip)
set -euo pipefail
cd "$(dirname "$0")/../.."
python=${1:-${PYTHON:-python3}}
target=.oidn
lib=$target/pyoidn/oidn/lib
if [ -e "$lib/libOpenImageDenoise.so" ] && [ "$(cat "$target/.version" 2>/dev/null)" = "2.5.1.0" ]; then
    echo "OIDN already in $target"
    exit 0
fi
rm -rf "$target"
# No dependencies: only the library is used (not the wheel's Python API, which wants numpy).
"$python" -m pip install -q --disable-pip-version-check --no-deps --target "$target" pyoidn==2.5.1.0
test -e "$lib/libOpenImageDenoise.so"
echo "2.5.1.0" > "$target/.version"
echo "OIDN 2.5.1 installed in $target (OIDN_DIR=$PWD/$target/pyoidn/oidn)"
