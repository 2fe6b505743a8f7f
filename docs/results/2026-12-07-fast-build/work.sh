#!/bin/bash
# usage: work.sh builder...  -> docs/results/2026-12-07-fast-build/work_per_ray.tsv rows: builder scene rays work
SCENES=${SCENES:-"sponza_dabrovic sibenik stanford_bunny utah_teapot teapot_in_stadium san_francisco_osm gltf_2cylinder_engine lamborghini_huracan_gt3 sd_macross_diorama"}
RAYS=${RAYS:-"primary diffuse ao"}
for b in "$@"; do for s in $SCENES; do for r in $RAYS; do
  if grep -q "^$b	$s	$r	" docs/results/2026-12-07-fast-build/work_per_ray.tsv 2>/dev/null; then continue; fi
  w=$(target/release/xtask trace --scene $s --builder $b --layout bvh8 --rays $r --passes 1 --json 2>/dev/null | python3 -c 'import json,sys; d=json.load(sys.stdin); print(1.2*d["inner_per_ray"]+d["triangles_per_ray"])')
  printf "%s\t%s\t%s\t%s\n" $b $s $r $w >> docs/results/2026-12-07-fast-build/work_per_ray.tsv
done; done; done
