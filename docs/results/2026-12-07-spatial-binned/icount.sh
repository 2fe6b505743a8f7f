#!/bin/bash
# usage: icount.sh scene builder [env...]; prints instructions inside the builder's build_tree (1 thread)
scene=$1; b=$2; shift 2
out=$(mktemp)
env "$@" valgrind --tool=callgrind --callgrind-out-file=$out --toggle-collect='*Strategy*build_tree*' ${X:-target/release/xtask} bvh --scene $scene --builder $b --threads 1 --runs 1 --no-epo >/dev/null 2>&1
callgrind_annotate $out 2>/dev/null | grep -m1 "PROGRAM TOTALS" | awk '{print $1}'
rm -f $out
