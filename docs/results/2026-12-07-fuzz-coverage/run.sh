#!/bin/bash
# The coverage of the saved `big_scene` corpus over sahara's unsafe code and parallel
# thresholds (issue 46, item 4; docs/robustness.md, "Coverage of the saved corpus").
# Needs the nightly toolchain with llvm-tools and cargo-fuzz. Writes, next to this script,
# report.txt (llvm-cov's per-file summary of crates/traverse/src/wide and
# crates/builders/src/split) and unsafe-and-thresholds.md (every line with `unsafe` in those
# files and every parallel-threshold test, with its execution count).
# Usage: docs/results/2026-12-07-fuzz-coverage/run.sh [TARGET] [CORPUS]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(git -C "$here" rev-parse --show-toplevel)
target=${1:-big_scene}
corpus=${2:-corpus/$target}
cd "$root/fuzz"
# No sanitizer: coverage needs only the instrumentation, and ASan would triple the time.
cargo +nightly fuzz coverage --sanitizer none "$target" "$corpus"
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
python3 "$here/unsafe_lines.py" "$here/show.txt" > "$here/unsafe-and-thresholds.md"
rm "$here/show.txt"
echo "wrote $here/report.txt and $here/unsafe-and-thresholds.md"
