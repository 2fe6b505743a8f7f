#!/bin/bash
# SAH, node count and depth of `binned` on the ten shared scenes, for each binary given
# (an old and a new build of `target/release/xtask`); one build per scene, two threads.
# usage: sah.sh OLD_XTASK NEW_XTASK > sah.txt
for scene in sponza_dabrovic sibenik stanford_bunny stanford_dragon utah_teapot \
    teapot_in_stadium san_francisco_osm gltf_2cylinder_engine lamborghini_huracan_gt3 \
    sd_macross_diorama; do
  for bin in "$@"; do
    nice -n 10 "$bin" bvh --scene "$scene" --builder binned --threads 2 --runs 1 --no-epo --json \
      | python3 -c "import json,sys; d=json.load(sys.stdin); print('%-24s %-22s sah %.6f nodes %d depth %d' % ('$scene', '$(basename $bin)', d['sah'], d['nodes'], d['depth']))"
  done
done
