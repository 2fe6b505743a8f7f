#!/usr/bin/env bash
# The runs behind README.md (docs/results/2026-12-02-isa-xeon): the ISA-matched comparison on
# every shared scene, one thread, all three ray types, sweep and SBVH trees. Two binaries:
#   A: cargo build --release -p xtask --features embree,obvhs            (ordinary flags)
#   B: RUSTFLAGS="-C target-feature=+avx2,+fma" cargo build --release -p xtask --features tinybvh
# XTASK_A and XTASK_B point at them; OUT is where the eval folders go. Nothing else may run.
set -euo pipefail
: "${XTASK_A:?}" "${XTASK_B:?}" "${OUT:?}"
scenes=sponza_dabrovic,sibenik,stanford_bunny,stanford_dragon,utah_teapot,teapot_in_stadium
scenes+=,san_francisco_osm,sd_macross_diorama,lamborghini_huracan_gt3,gltf_2cylinder_engine
common=(eval --scenes "$scenes" --builders sweep,sbvh --rays primary,diffuse,ao
        --threads "${THREADS:-1}" --width "${WIDTH:-1024}" --height "${HEIGHT:-768}" --passes "${PASSES:-9}"
        --round-budget "${BUDGET:-8}" --build-runs 1 --no-scaling)
for isa in ${ISAS:-avx512 avx2 sse2 tinybvh}; do
  case $isa in
    avx512|avx2) "$XTASK_A" "${common[@]}" --layouts bvh8,embree,obvhs --backend "$isa" --out "$OUT/$isa" ;;
    sse2) "$XTASK_A" "${common[@]}" --layouts bvh4,embree --backend sse2 --out "$OUT/sse2" ;;
    tinybvh) "$XTASK_B" "${common[@]}" --layouts bvh8,tinybvh,tinybvh-hq --backend avx2 --out "$OUT/tinybvh-avx2" ;;
  esac
done
