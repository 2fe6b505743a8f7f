#!/bin/bash
# bvh8 work per ray (counters) of the High candidates on every shared scene
export SAHARA_SCENES=${SAHARA_SCENES:-../shared/scenes}
X=${X:-target/release/xtask}
for scene in sponza_dabrovic sibenik stanford_bunny stanford_dragon utah_teapot teapot_in_stadium san_francisco_osm sd_macross_diorama lamborghini_huracan_gt3 gltf_2cylinder_engine; do
 for b in sweep sbvh sbvh-fast spatial-binned embree-high; do
  for r in primary diffuse ao; do
   $X trace --scene $scene --builder $b --layout bvh8 --rays $r --passes 1 --json 2>/dev/null
  done
 done
done
