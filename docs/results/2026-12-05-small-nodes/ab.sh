#!/bin/bash
# usage: A=path/to/new/xtask B=path/to/old/xtask ab.sh ROUNDS SCENES BUILDERS THREADS
# A and B are two release builds of xtask (for example target/release/xtask and a
# second target directory built from the older commit).
A=${A:?set A to the new xtask binary}
B=${B:?set B to the old xtask binary}
for r in $(seq 1 "$1"); do
  for x in A B; do
    bin=${!x}
    "$bin" build-bench --scenes "$2" --builders "$3" --rounds 1 --threads "$4" 2>/dev/null | awk -v t=$x -v r=$r '$2 ~ /^(sweep|tsah-topk|binned|sbvh|hybrid)$/ {print r, t, $1, $2, $3}'
  done
done
