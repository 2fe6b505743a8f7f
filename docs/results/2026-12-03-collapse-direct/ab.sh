#!/bin/bash
# usage: ab.sh binA binB scene rounds threads [extra args]
A=$1; B=$2; S=$3; R=${4:-5}; T=${5:-1}; shift 5; X="$@"
for i in $(seq $R); do
  a=$($A --scene $S --runs 11 --threads $T $X | sed -E 's/.*: ([0-9.]+) ms median.*/\1/')
  b=$($B --scene $S --runs 11 --threads $T $X | sed -E 's/.*: ([0-9.]+) ms median.*/\1/')
  echo "$a $b"
done | python3 -c "
import sys,statistics
rows=[tuple(map(float,l.split())) for l in sys.stdin if l.strip()]
r=[a/b for a,b in rows]
print('A', [a for a,_ in rows]); print('B', [b for _,b in rows])
print('A/B per round', [round(x,3) for x in r], 'median', round(statistics.median(r),3))"
