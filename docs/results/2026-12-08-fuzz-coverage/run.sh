#!/bin/bash
# The coverage of `big_scene` corpora over sahara's unsafe code and parallel thresholds, as
# docs/results/2026-12-07-fuzz-coverage/run.sh (whose line-listing script this reuses) but
# over several corpus directories and writing next to this script (report.txt,
# unsafe-and-thresholds.md). Needs the nightly toolchain with llvm-tools and cargo-fuzz.
# Usage: docs/results/2026-12-08-fuzz-coverage/run.sh [CORPUS...]  (paths relative to fuzz/;
# default: corpus/big_scene corpus-pending/big_scene)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(git -C "$here" rev-parse --show-toplevel)
target=big_scene
if [ $# -eq 0 ]; then set -- corpus/big_scene corpus-pending/big_scene; fi
cd "$root/fuzz"
# No sanitizer: coverage needs only the instrumentation, and ASan would triple the time.
nice -n 10 cargo +nightly fuzz coverage --sanitizer none "$target" "$@"
host=$(rustc +nightly -vV | sed -n 's/^host: //p')
llvm_cov="$(rustc +nightly --print sysroot)/lib/rustlib/$host/bin/llvm-cov"
bin="target/$host/coverage/$host/release/$target"
prof="coverage/$target/coverage.profdata"
mapfile -t files < <(find "$root/crates/traverse/src/wide" "$root/crates/builders/src/split" -name '*.rs' | sort)
# The other places a parallel threshold is tested.
extra=("$root/crates/builders/src/rules/binned.rs" "$root/crates/builders/src/cluster_binned.rs"
       "$root/crates/builders/src/rules/greedy.rs" "$root/crates/builders/src/topdown.rs")
"$llvm_cov" report "$bin" -instr-profile="$prof" "${files[@]}" \
    | sed "s|$root/||g" > "$here/report.txt"
"$llvm_cov" show "$bin" -instr-profile="$prof" -show-line-counts "${files[@]}" "${extra[@]}" \
    | sed "s|$root/||g" > "$here/show.txt"
python3 "$root/docs/results/2026-12-07-fuzz-coverage/unsafe_lines.py" "$here/show.txt" \
    > "$here/unsafe-and-thresholds.md"
rm "$here/show.txt"
echo "wrote $here/report.txt and $here/unsafe-and-thresholds.md"
