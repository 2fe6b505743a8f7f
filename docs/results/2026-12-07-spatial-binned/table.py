import json, sys, math, collections
ct = 1.2
w = {}
for line in open(sys.argv[1]):
    line=line.strip()
    if not line.startswith('{'): continue
    r = json.loads(line)
    w[(r['scene'], r['builder'], r['ray_kind'])] = ct*r['inner_per_ray'] + r['triangles_per_ray']
scenes = sorted({k[0] for k in w})
builders = ['sbvh','sbvh-fast','spatial-binned','embree-high']
kinds = ['primary','diffuse','ao']
def gm(xs): return math.exp(sum(math.log(x) for x in xs)/len(xs)) if xs else float('nan')
print("| scene | rays | " + " | ".join(f"`{b}`" for b in builders) + " | `spatial-binned` ÷ Embree HIGH's tree |")
print("|---|---|" + "---:|"*(len(builders)+1))
for s in scenes:
    for k in kinds:
        if (s,'sweep',k) not in w: continue
        cells=[]
        for b in builders:
            cells.append(f"{w[(s,'sweep',k)]/w[(s,b,k)]:.3f}" if (s,b,k) in w else "–")
        e = f"{w[(s,'spatial-binned',k)]/w[(s,'embree-high',k)]:.3f}" if (s,'embree-high',k) in w and (s,'spatial-binned',k) in w else "–"
        print(f"| {s} | {k} | " + " | ".join(cells) + f" | {e} |")
print()
print("geomean over scenes (sweep's work ÷ builder's; above 1: less work than sweep):")
for b in builders:
    row=[]
    for k in kinds:
        xs=[w[(s,'sweep',k)]/w[(s,b,k)] for s in scenes if (s,b,k) in w and (s,'sweep',k) in w]
        row.append(f"{gm(xs):.3f} (n={len(xs)})")
    print(f"  {b}: " + " / ".join(row))
xs={k:[w[(s,'spatial-binned',k)]/w[(s,'embree-high',k)] for s in scenes if (s,'embree-high',k) in w and (s,'spatial-binned',k) in w] for k in kinds}
print("spatial-binned ÷ embree-high work: " + " / ".join(f"{k} max {max(v):.3f} geomean {gm(v):.3f}" for k,v in xs.items() if v))
