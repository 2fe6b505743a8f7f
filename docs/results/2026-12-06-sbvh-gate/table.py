#!/usr/bin/env python3
"""sbvh against sbvh-fast from `xtask build-bench --json` (README.md of this folder):
`table.py build-bench-sbvh.json`. Times are build + collapse to bvh8; ratios are build-bench's
own (median over rounds of the per-round ratio to Embree HIGH)."""
import json
import sys

rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip().startswith("{")]
by = {}
for r in rows:
    by.setdefault(r["scene"], {})[r["engine"]] = r
print("| scene | sbvh ms | ÷ HIGH | sbvh-fast ms | ÷ HIGH | sbvh-fast ÷ sbvh | SAH sbvh | SAH sbvh-fast | SAH change |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for s, d in by.items():
    a, b = d["sbvh"], d["sbvh-fast"]
    ra = a["ratios"][0][1]["median"]
    rb = b["ratios"][0][1]["median"]
    ta, tb = a["total_ms"]["median"], b["total_ms"]["median"]
    print(f"| {s} | {ta:.1f} | {ra:.2f} | {tb:.1f} | {rb:.2f} | {tb / ta:.2f} | {a['sah']:.3f} | "
          f"{b['sah']:.3f} | {b['sah'] / a['sah'] - 1:+.2%} |")
