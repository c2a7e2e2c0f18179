#!/usr/bin/env bash
# The traversal bench with Embree 3 beside torrey's BVH, on the same rays, one thread.
# Installs Debian's libembree-dev (Embree 3.13) when the header is missing, then runs
#   cargo bench -p torrey-renderer --bench traversal --features embree -- [scene filters]
# TORREY_EMBREE_QUALITY=low|medium|high chooses Embree's build quality (default high).
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -e /usr/include/embree3/rtcore.h ]; then
    sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get install -y libembree-dev
fi
exec cargo bench -p torrey-renderer --bench traversal --features embree -- "$@"
