#!/usr/bin/env bash
# Short fuzz run for CI: each harness of fuzz/ (torrey-fuzz) for a bounded time, at most about
# 2 minutes in all (SECONDS_PER_TARGET=25 by default, four targets), under a 4 GB address-space
# cap so that a runaway allocation aborts instead of eating the machine. Exits non-zero on a
# panic (status 1), a hang (status 3), a crash or abort (killed by a signal) or a harness that
# overran its time. The input at fault is left in target/fuzz/TARGET/ (panic-N.*, hang.*,
# or current.* after a crash). Longer runs: docs/robustness.md.
set -uo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET="${SECONDS_PER_TARGET:-25}"
cargo build --profile ci -p torrey-fuzz --quiet || exit 1
status=0
for target in xml mesh image render; do
    (
        ulimit -v 4000000
        timeout -s KILL $((SECONDS_PER_TARGET + 30)) \
            target/ci/torrey-fuzz "$target" --seconds "$SECONDS_PER_TARGET" --timeout 10 \
            --seed "${FUZZ_SEED:-$RANDOM}"
    )
    rc=$?
    if [ "$rc" -ne 0 ]; then
        echo "fuzz: target $target failed with status $rc; inputs in target/fuzz/$target/" >&2
        ls -la "target/fuzz/$target/" >&2
        status=1
    fi
done
exit $status
