#!/bin/bash
# build-bench of `binned`, the old and the new binary alternated, PAIRS times each.
# usage: bench.sh OLD_XTASK NEW_XTASK PAIRS > bench.txt
old=$1; new=$2; pairs=${3:-2}
for i in $(seq "$pairs"); do
  for bin in "$old" "$new"; do
    echo "== $(basename "$bin") (pair $i), load: $(cut -d' ' -f1-3 /proc/loadavg)"
    nice -n 10 "$bin" build-bench --scenes sponza_dabrovic,sibenik --builders binned --rounds 5 --threads 2 2>/dev/null \
      | grep -E '^(sponza|sibenik|[0-9]+ rounds)'
  done
done
