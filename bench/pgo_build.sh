#!/usr/bin/env bash
# Profile-guided optimisation (PGO) build of torrey: writes target/pgo/torrey.
#
#   bash bench/pgo_build.sh
#
# 1. builds an instrumented torrey (target/pgo/gen), 2. renders every scene in scenes/ at 8 spp
# with both samplers to record which branches and calls are hot (8 spp, so that camera rays go in
# packets: at 4 spp the packet code was never run and the profile made it cold, which cost
# textured_mesh 17% and the living room 29% against the release build), 3. merges the
# profiles with the toolchain's llvm-profdata (rustup's llvm-tools component, added if missing;
# its LLVM version must match rustc's), 4. rebuilds torrey with the profile (target/pgo/use).
# The training scenes are the project's own, so a fresh clone can run this. About 5 minutes on
# 2 cores. The result renders the same images as `cargo build --release` (PGO only changes code
# layout, inlining and branch order); docs/performance.md gives what it gains.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
dir=$root/target/pgo

sysroot=$(rustc --print sysroot)
host=$(rustc -vV | sed -n 's/^host: //p')
profdata=$sysroot/lib/rustlib/$host/bin/llvm-profdata
if [ ! -x "$profdata" ]; then
    echo "pgo_build: adding rustup component llvm-tools (for llvm-profdata)" >&2
    rustup component add llvm-tools
fi

rm -rf "$dir/profiles"
mkdir -p "$dir/profiles"
echo "pgo_build: 1/4 instrumented build" >&2
RUSTFLAGS="-Cprofile-generate=$dir/profiles" \
    cargo build --release --quiet --target-dir "$dir/gen" --bin torrey

echo "pgo_build: 2/4 training renders (scenes/*.xml)" >&2
for scene in scenes/*.xml; do
    for sampler in independent sobol; do
        "$dir/gen/release/torrey" "$scene" -o "$dir/train.exr" --spp 8 --sampler "$sampler" \
            --quiet 2>/dev/null
    done
done

echo "pgo_build: 3/4 merging profiles" >&2
"$profdata" merge -o "$dir/merged.profdata" "$dir/profiles"

echo "pgo_build: 4/4 optimised build" >&2
RUSTFLAGS="-Cprofile-use=$dir/merged.profdata" \
    cargo build --release --quiet --target-dir "$dir/use" --bin torrey
cp "$dir/use/release/torrey" "$dir/torrey"
rm -f "$dir/train.exr" "$dir/train.png"
echo "pgo_build: wrote target/pgo/torrey" >&2
