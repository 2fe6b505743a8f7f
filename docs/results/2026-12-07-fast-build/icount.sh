#!/bin/bash
# usage: icount.sh scene builder pattern
scene=$1; b=$2; pat=${3:-'*build_tree*'}
out=$(mktemp)
valgrind --tool=callgrind --callgrind-out-file=$out --toggle-collect="$pat" target/release/xtask bvh --scene $scene --builder $b --threads 1 --runs 1 --no-epo >/dev/null 2>&1
callgrind_annotate $out 2>/dev/null | grep -m1 "PROGRAM TOTALS" | awk '{print $1}'
rm -f $out
