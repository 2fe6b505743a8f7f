#!/bin/bash
# Instructions of one single-threaded `binned` build (callgrind, the build only), per binary.
# usage: callgrind.sh SCENE XTASK... > callgrind-SCENE.txt
scene=$1; shift
for bin in "$@"; do
  out=$(mktemp)
  nice -n 10 valgrind --tool=callgrind --callgrind-out-file="$out" \
    --toggle-collect='*as sahara_builders::Builder>::build' \
    "$bin" bvh --scene "$scene" --builder binned --threads 1 --runs 1 --no-epo >/dev/null 2>&1
  echo "$scene $(basename "$bin") $(grep '^totals' "$out")"
  rm -f "$out"
done
