#!/usr/bin/env bash
# Embree's trees through sahara's kernels (docs/results/2026-12-05-embree-trees): one thread,
# interleaved rounds, the ten shared scenes.
set -euo pipefail
X=${XTASK:?}; OUT=${OUT:?}
scenes=sponza_dabrovic,sibenik,stanford_bunny,stanford_dragon,utah_teapot,teapot_in_stadium
scenes+=,san_francisco_osm,sd_macross_diorama,lamborghini_huracan_gt3,gltf_2cylinder_engine
common=(eval --scenes "$scenes" --rays primary,diffuse,ao --threads 1 --width 640 --height 480
        --passes 3 --round-budget 4 --build-runs 1 --no-scaling --layouts bvh8,embree)
for isa in ${ISAS:-avx2}; do
  "$X" "${common[@]}" --builders sweep,embree-medium --backend "$isa" --out "$OUT/$isa-medium"
  SAHARA_EMBREE_QUALITY=high "$X" "${common[@]}" --builders sbvh,embree-high --backend "$isa" --out "$OUT/$isa-high"
done
