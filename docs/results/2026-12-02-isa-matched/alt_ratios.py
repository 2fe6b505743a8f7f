#!/usr/bin/env python3
"""Per-round ratios from alternate.sh's JSON lines: sahara's Mrays/s / Embree's, per ISA,
scene and ray kind (median, min-max over rounds), with both engines' median Mrays/s."""
import json
import statistics
import sys
from collections import defaultdict

cells = defaultdict(dict)
for line in open(sys.argv[1]):
    line = line.strip()
    if not line.startswith("{"):
        continue
    r = json.loads(line)
    engine = "embree" if r["layout"] == "embree" else "sahara"
    isa = r["backend"]
    key = (isa, r["scene"], r["ray_kind"])
    cells[key].setdefault(r["round"], {})[engine] = r
print("| scene | rays | sahara (layout, backend) | Embree ISA | sahara Mrays/s | Embree Mrays/s | sahara / Embree: median (min–max), rounds |")
print("|---|---|---|---|---:|---:|---|")
for (isa, scene, kind), rounds in cells.items():
    q, a, b = [], [], []
    for rd in rounds.values():
        if "sahara" in rd and "embree" in rd:
            s, e = rd["sahara"], rd["embree"]
            q.append(s["mrays_s"]["median"] / e["mrays_s"]["median"])
            a.append(s["mrays_s"]["median"])
            b.append(e["mrays_s"]["median"])
            lay, sb, eb = s["layout"], s["backend"], e["backend"]
    if q:
        print(f"| {scene} | {kind} | {lay} {sb} | {eb} | {statistics.median(a):.2f} | "
              f"{statistics.median(b):.2f} | **{statistics.median(q):.2f}** ({min(q):.2f}–{max(q):.2f}), {len(q)} |")
