#!/usr/bin/env bash
# The runs behind README.md (docs/results/2026-12-02-isa-matched). Two binaries:
#   A: cargo build --release -p xtask --features embree,obvhs            (ordinary flags)
#   B: RUSTFLAGS="-C target-feature=+avx2,+fma" cargo build --release -p xtask --features tinybvh
# XTASK_A and XTASK_B point at them; OUT is where the eval folders go.
set -euo pipefail
: "${XTASK_A:?}" "${XTASK_B:?}" "${OUT:?}"
common=(eval --scenes sponza_dabrovic,sibenik,stanford_bunny --builders sweep,sbvh
        --rays primary,diffuse --threads 1 --width 512 --height 384 --passes "${PASSES:-7}"
        --build-runs 1 --no-scaling)
nice -n 10 "$XTASK_A" "${common[@]}" --layouts bvh8,embree,obvhs --backend avx512 --out "$OUT/avx512"
nice -n 10 "$XTASK_A" "${common[@]}" --layouts bvh8,embree,obvhs --backend avx2 --out "$OUT/avx2"
nice -n 10 "$XTASK_A" "${common[@]}" --layouts bvh4,embree --backend sse2 --out "$OUT/sse2"
nice -n 10 "$XTASK_B" "${common[@]}" --layouts bvh8,tinybvh,tinybvh-hq --backend avx2 --out "$OUT/tinybvh-avx2"
