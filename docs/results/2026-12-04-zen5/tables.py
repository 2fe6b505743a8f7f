#!/usr/bin/env python3
"""Per-scene tables (README.md of docs/results/2026-12-04-zen5) from the rows that
`../2026-12-02-isa-xeon/ratios.py` prints: `tables.py ratios.md`. A cell is the median ratio
(other engine's time / sahara's, > 1: sahara faster); "≈" marks a tie (the 95% interval
contains 1), "−" a loss (the interval lies below 1)."""
import re
import sys
from collections import defaultdict

SCENES = ["sponza_dabrovic", "sibenik", "stanford_bunny", "stanford_dragon", "utah_teapot",
          "teapot_in_stadium", "san_francisco_osm", "sd_macross_diorama",
          "lamborghini_huracan_gt3", "gltf_2cylinder_engine"]
cells = defaultdict(dict)
for line in open(sys.argv[1]):
    f = [x.strip() for x in line.split("|")[1:-1]]
    if len(f) != 9 or f[0] == "run" or f[0].startswith("-"):
        continue
    run, scene, rays, tree, other, _, _, ratio, verdict = f
    r = re.search(r"\*\*([0-9.]+)\*\*", ratio).group(1)
    mark = {"tie": "≈", "loss": "−", "win": ""}[verdict]
    other = other.split()[0]
    cells[(run, other)][(scene, tree.split()[-1], rays)] = mark + r
for (run, other), c in cells.items():
    trees = sorted({k[1] for k in c}, reverse=True)
    print(f"\n**{run}: sahara / {other}** (primary / diffuse / AO)\n")
    print("| scene | " + " | ".join(f"{t} tree" for t in trees) + " |")
    print("|---|" + "---|" * len(trees))
    for s in SCENES:
        row = [" / ".join(c.get((s, t, r), "n/a") for r in ("primary", "diffuse", "ao"))
               for t in trees]
        print(f"| {s} | " + " | ".join(row) + " |")
