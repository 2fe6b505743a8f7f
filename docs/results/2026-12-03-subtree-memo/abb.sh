#!/bin/bash
# abb.sh binA binB builder scene rounds threads  -> per-round medians of A and B
A=$1; B=$2; bld=$3; sc=$4; R=${5:-3}; T=${6:-1}
for r in $(seq $R); do
  for x in A B; do
    bin=${!x}
    v=$($bin bvh --scene $sc --builder $bld --json --no-epo --runs ${RUNS:-5} --threads $T | python3 -c "import json,sys; d=json.load(sys.stdin); print(d['build_ms']['median'], d['sah'])")
    echo "$x $v"
  done
done | python3 -c "
import sys,statistics as st
a=[];b=[]
for l in sys.stdin:
  x,v,s=l.split(); (a if x=='A' else b).append(float(v)); sah=s
r=[y/x for x,y in zip(a,b)]
print('$sc $bld A %.1f B %.1f  B/A median %.3f range %.3f-%.3f'%(st.median(a),st.median(b),st.median(r),min(r),max(r)))
"
