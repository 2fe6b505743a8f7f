#!/bin/bash
# usage: run.sh scene rays engine(sahara|embree) passes -> total Ir and D1/LL misses
scene=$1; rays=$2; eng=$3; passes=$4
out=${OUT:-/tmp}/cg.$scene.$rays.$eng.$passes
# run from the workspace root, xtask built with --features embree (X= another binary)
valgrind --tool=callgrind --cache-sim=yes --branch-sim=yes --callgrind-out-file=$out ${X:-target/release/xtask} trace --scene $scene --builder sweep --layout bvh8 --engine $eng --backend avx2 --rays $rays --width 320 --height 240 --passes $passes --threads 1 > $out.log 2>&1
grep -E "refs|misses|Mispred|Branches" $out.log | tr '\n' ' ' ; echo
