#!/usr/bin/env bash
# Packet pairs (issue 14): the bvh8 kernels before (KB_BASE) and after (KB_PAIR) the 8-lane test
# of two packets at once, same tree (sweep), same rays, one thread, alternating per round.
# Ray files: `cargo xtask trace --scene S --builder sweep --rays K --layout bvh8 --threads 1
# --passes 1 --dump-rays target/pair-rays/S.K.rays` (as in ../2026-12-03-price-of-exactness).
set -euo pipefail
R=${RAYS:-target/pair-rays}
ROUNDS=${ROUNDS:-3}
scenes=${SCENES:-"sponza_dabrovic sibenik stanford_bunny stanford_dragon utah_teapot teapot_in_stadium san_francisco_osm sd_macross_diorama lamborghini_huracan_gt3 gltf_2cylinder_engine"}
for s in $scenes; do for k in primary diffuse ao; do
  any=""; [ $k = ao ] && any="--any"
  for backend in ${BACKENDS:-avx2 avx512}; do
    for round in $(seq $ROUNDS); do
      for kern in base pair; do
        bin=$KB_BASE; [ $kern = pair ] && bin=$KB_PAIR
        line=$($bin --scene $s --rays $R/$s.$k.rays --layout ${LAYOUT:-bvh8} --backend $backend --passes 3 $any 2>&1 | tail -1)
        echo "$s $k $backend $round $kern $line"
      done
    done
  done
done; done
