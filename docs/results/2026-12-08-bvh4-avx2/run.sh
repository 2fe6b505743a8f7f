#!/bin/bash
# bvh4 vs bvh8 at AVX2 (and embree isa=avx2) per ray type, interleaved rounds, one thread.
X=${X:-target/release/xtask}  # run from the workspace root
export SAHARA_EMBREE_CONFIG=isa=avx2
for round in 1 2 3 4 5; do
 for scene in sponza_dabrovic sibenik; do
  for rays in primary diffuse ao; do
   engines="bvh4 bvh8 embree"; [ $((round%2)) = 0 ] && engines="embree bvh8 bvh4"
   for e in $engines; do
     if [ $e = embree ]; then a="--engine embree"; else a="--layout $e --backend avx2"; fi
     r=$($X trace --scene $scene --builder sweep --rays $rays $a --threads 1 --json --passes 5 2>/dev/null | python3 -c 'import json,sys;d=json.load(sys.stdin);print(d["mrays_s"]["median"],d.get("inner_per_ray",0),d.get("leaves_per_ray",0))')
     echo "$round $scene $rays $e $r"
   done
  done
 done
done
