#!/usr/bin/env bash
# Python package and Ray tests: a venv with the pinned tools (python/requirements-ci.txt; reused
# while the pins are unchanged), the command line and the `torrey` package built with the `ci`
# profile, then pytest: the API tests and the Ray tests on a two-node cluster on this machine.
# Usage: .ci/python.sh [pytest arguments]. TORREY_PY_VENV picks the venv folder.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=$(realpath -m "${TORREY_PY_VENV:-.venv-python}")
python=${PYTHON:-python3}
pins=$(grep -v '^#' python/requirements-ci.txt)
if [ ! -x "$venv/bin/python" ] || [ "$(cat "$venv/.pins" 2>/dev/null)" != "$pins" ]; then
    "$python" -m venv "$venv"
    "$venv/bin/pip" install -q --disable-pip-version-check -r python/requirements-ci.txt
    echo "$pins" > "$venv/.pins"
fi
export PATH="$venv/bin:$PATH"
cargo build -q --profile ci -p torrey
# With the project's OIDN installed (crates/denoise/install-oidn.sh), the package denoises.
if [ -e .oidn/pyoidn/oidn/lib/libOpenImageDenoise.so ]; then
    export MATURIN_PEP517_ARGS="--features denoise"
fi
pip install -q --disable-pip-version-check --no-build-isolation --no-deps --force-reinstall ./python
python -m pytest -q python/tests "$@"
