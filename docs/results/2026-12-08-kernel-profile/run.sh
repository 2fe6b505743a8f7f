#!/bin/bash
# Per-instruction profile of one kernel entry point over one ray set (issue 43, 2026-12-08).
# usage (from the workspace root, xtask built with --features embree):
#   run.sh sahara SCENE RAYS SYMBOL_GLOB   e.g. run.sh sahara sibenik ao '*any_hit_avx2*'
#   run.sh embree SCENE RAYS SYMBOL        e.g. run.sh embree sibenik ao rtcOccluded1
# Writes $OUT/kp.ENGINE.SCENE.RAYS (OUT: a scratch directory, default target/) (callgrind, --dump-instr=yes), then per-address counts
# (perinstr.py). Divide by the calls of the entry point (the count of its first instruction)
# to get instructions per ray; objdump the entry point and join on the address to see blocks.
eng=$1; scene=$2; rays=$3; sym=$4
out=${OUT:-target}/kp.$eng.$scene.$rays
if [ "$eng" = embree ]; then e="--engine embree"; export SAHARA_EMBREE_CONFIG=isa=avx2; else e="--layout bvh8 --backend avx2"; fi
valgrind --tool=callgrind --dump-instr=yes --toggle-collect="$sym" --callgrind-out-file=$out \
  ${X:-target/release/xtask} trace --scene $scene --builder sweep $e --rays $rays \
  --width 320 --height 240 --passes 1 --threads 1 > $out.log 2>&1
python3 "$(dirname "$0")/perinstr.py" $out > $out.addr
echo "$out.addr"
