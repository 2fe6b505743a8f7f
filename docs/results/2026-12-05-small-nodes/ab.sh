#!/bin/bash
# usage: ab.sh ROUNDS SCENES BUILDERS THREADS
A=/work/main/target/release/xtask; B=/work/target-pairs/release/xtask
for r in $(seq 1 $1); do
  for x in A B; do
    bin=${!x}
    $bin build-bench --scenes $2 --builders $3 --rounds 1 --threads $4 2>/dev/null | awk -v t=$x -v r=$r '$2 ~ /^(sweep|tsah-topk|binned|sbvh|hybrid)$/ {print r, t, $1, $2, $3}'
  done
done
