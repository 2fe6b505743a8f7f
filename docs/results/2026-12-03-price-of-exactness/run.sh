#!/usr/bin/env bash
# Price of exactness: the exact AVX2 bvh8 kernel against the benchmark-only inexact one
# (Möller–Trumbore, no shear, no fallback, no accept_hit clamp), same tree, same rays, one thread.
set -euo pipefail
X=${XTASK:-target/release/xtask}
KB=${KB:-target/release/examples/kernel_bench}
R=${RAYS:-target/price-rays}
mkdir -p $R
scenes="sponza_dabrovic sibenik stanford_bunny stanford_dragon utah_teapot teapot_in_stadium san_francisco_osm sd_macross_diorama lamborghini_huracan_gt3 gltf_2cylinder_engine"
for s in $scenes; do for k in primary diffuse ao; do
  [ -f $R/$s.$k.rays ] || $X trace --scene $s --builder sweep --rays $k --layout bvh8 --threads 1 --passes 1 --dump-rays $R/$s.$k.rays >/dev/null 2>&1
done; done
for s in $scenes; do for k in primary diffuse ao; do
  any=""; [ $k = ao ] && any="--any"
  for round in 1 2 3; do
    for kern in exact inexact; do
      flag=""; [ $kern = inexact ] && flag="--inexact"
      line=$($KB --scene $s --rays $R/$s.$k.rays --layout bvh8 --backend avx2 --passes 5 $any $flag 2>&1 | tail -1)
      echo "$s $k $round $kern $line"
    done
  done
done; done
