#!/bin/bash
# The coverage of several `big_scene` corpus directories over sahara's unsafe code and
# parallel thresholds: docs/results/2026-12-07-fuzz-coverage/run.sh (which takes one corpus)
# over a merged copy of them, its outputs (report.txt, unsafe-and-thresholds.md) moved here
# and its own restored from git. Needs the nightly toolchain with llvm-tools and cargo-fuzz.
# Usage: docs/results/2026-12-08-fuzz-coverage/run.sh [CORPUS...]  (paths relative to fuzz/;
# default: corpus/big_scene, which since holds the two seeds of corpus-pending/big_scene)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(git -C "$here" rev-parse --show-toplevel)
old="$root/docs/results/2026-12-07-fuzz-coverage"
if [ $# -eq 0 ]; then set -- corpus/big_scene; fi
merged=$(mktemp -d)
for c in "$@"; do cp "$root/fuzz/$c"/* "$merged/"; done
nice -n 10 "$old/run.sh" big_scene "$merged"
mv "$old/report.txt" "$old/unsafe-and-thresholds.md" "$here/"
git -C "$root" checkout -- "$old/report.txt" "$old/unsafe-and-thresholds.md"
rm -r "$merged"
echo "moved them to $here"
