#!/bin/bash
# Interleaved A/B of two xtask binaries on AO rays (BASE: today's kernels; EXP: the binary built
# with the experiment's `--cfg`), six pairs per scene; prints round, scene, rays, binary, Mrays/s.
# usage: BASE=path/to/xtask EXP=path/to/xtask ab.sh (the first run, ab-fma-node-test.txt, traced
# `for r in ao diffuse`)
for i in 1 2 3 4 5 6; do for sc in sibenik sponza_dabrovic; do for r in ao; do for b in base fma; do X=$BASE; [ $b = fma ] && X=$EXP
m=$($X trace --scene $sc --builder sweep --layout bvh8 --backend avx2 --rays $r --threads 1 --json --width 640 --height 480 2>/dev/null | python3 -c 'import json,sys;print(json.load(sys.stdin)["mrays_s"]["median"])')
echo "$i $sc $r $b $m"; done; done; done; done
