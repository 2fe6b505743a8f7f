#!/usr/bin/env python3
"""Per-round ratios new / old of the A/B files written by ab.sh (A = new, B = old)."""
import collections, statistics, sys

for path in sys.argv[1:]:
    d = collections.defaultdict(dict)
    for line in open(path):
        r, t, scene, builder, ms = line.split()
        d[(scene, builder, r)][t] = float(ms)
    agg = collections.defaultdict(list)
    for (scene, builder, _), x in d.items():
        agg[(scene, builder)].append(x["A"] / x["B"])
    print(f"{path}")
    for (scene, builder), v in sorted(agg.items()):
        print(f"  {scene:18} {builder:10} median new/old {statistics.median(v):.3f}  rounds {' '.join(f'{x:.3f}' for x in v)}")
