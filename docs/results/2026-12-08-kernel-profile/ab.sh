#!/bin/bash
for i in 1 2 3 4 5 6; do for sc in sibenik sponza_dabrovic; do for r in ao; do for b in base fma; do X=/tmp/xtask-base; [ $b = fma ] && X=/work/main/target/fma/release/xtask
m=$($X trace --scene $sc --builder sweep --layout bvh8 --backend avx2 --rays $r --threads 1 --json --width 640 --height 480 2>/dev/null | python3 -c 'import json,sys;print(json.load(sys.stdin)["mrays_s"]["median"])')
echo "$i $sc $r $b $m"; done; done; done; done
