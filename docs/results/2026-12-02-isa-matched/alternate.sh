#!/usr/bin/env bash
# Alternating `trace` processes (one JSON line each) for the AVX2 and SSE2 tables: per scene,
# ray kind and round, sahara's layout and Embree at the same ISA back to back, in an order
# that swaps every round. XTASK: the binary built with `--features embree`.
set -euo pipefail
: "${XTASK:?}"
ROUNDS=${ROUNDS:-3}
for isa in ${ISAS:-avx2 sse2}; do
  layout=bvh8; [ "$isa" = sse2 ] && layout=bvh4
  for scene in sponza_dabrovic sibenik stanford_bunny; do
    for rays in primary diffuse; do
      for round in $(seq 1 "$ROUNDS"); do
        engines=("--layout $layout" "--engine embree")
        [ $((round % 2)) = 0 ] && engines=("--engine embree" "--layout $layout")
        for e in "${engines[@]}"; do
          # shellcheck disable=SC2086
          nice -n 10 "$XTASK" trace --scene "$scene" --builder sweep --rays "$rays" \
            --threads 1 --width 512 --height 384 --passes 5 --backend "$isa" $e --json \
            | sed "s/^{/{\"round\":$round,/"
        done
      done
    done
  done
done
