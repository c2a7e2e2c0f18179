#!/usr/bin/env bash
# Creates tests/blender/.venv with Blender's Python module (bpy 5.0.1, Cycles included) so that
# torrey_to_blender.py and make_references.py can render reference images headless on the CPU.
# Idempotent: re-running only installs what is missing.
#
#   bash tests/blender/setup.sh
#
# bpy 5.0.1 needs Python 3.11 exactly; set PYTHON=/path/to/python3.11 if `python3` is another version.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"
py="${PYTHON:-}"
if [ -z "$py" ]; then
    for cand in python3.11 python3; do
        if command -v "$cand" >/dev/null 2>&1 &&
            "$cand" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)'; then
            py="$cand"
            break
        fi
    done
fi
if [ -z "$py" ]; then
    echo "setup.sh: bpy 5.0.1 needs Python 3.11; none found (set PYTHON=...)" >&2
    exit 1
fi
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import bpy, numpy, OpenEXR, sys; sys.exit(0 if bpy.app.version_string.startswith("5.0.1") else 1)' >/dev/null 2>&1; then
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet "bpy==5.0.1" numpy OpenEXR
fi
# Blender's OpenGL-free build still loads libX* / libSM at import time on some systems.
if ! "$venv/bin/python" -c 'import bpy' >/dev/null 2>&1; then
    echo "setup.sh: 'import bpy' failed; on Debian try: apt-get install -y libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 libgl1" >&2
    "$venv/bin/python" -c 'import bpy'
fi
echo "Blender $("$venv/bin/python" -c 'import bpy; print(bpy.app.version_string)') ready in $venv"
