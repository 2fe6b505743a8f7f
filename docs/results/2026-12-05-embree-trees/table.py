#!/usr/bin/env python3
"""Prints the tables of README.md from the eval results in this folder: per scene and ray kind,
speed ratios taken round by round (median of rounds) of sahara's bvh8 over sahara's own tree,
sahara's bvh8 over Embree's tree (`embree-medium` / `embree-high`) and Embree itself."""
import json, statistics, sys
def load(name):
    d = json.load(open(name))
    t = {}
    for r in d['traces']:
        t[(r['scene'], r['ray_kind'], r['builder'], r['layout'])] = r
    return t
for isa in ['avx2', 'avx512']:
    for q, own, et in [('medium', 'sweep', 'embree-medium'), ('high', 'sbvh', 'embree-high')]:
        t = load(f'{isa}-{q}.results.json')
        scenes = sorted({k[0] for k in t}, key=lambda s: [k[0] for k in t].index(s))
        print(f'\n**{isa}, Embree {q.upper()}** (ratios > 1: the first is faster; median of per-round ratios)\n')
        print(f'| scene | rays | {own} tree, sahara ÷ Embree | Embree\'s tree, sahara ÷ Embree | {own} tree ÷ Embree\'s tree (both sahara) | tris/ray {own} / Embree\'s tree |')
        print('|---|---|---:|---:|---:|---:|')
        for s in scenes:
            for k in ['primary', 'diffuse', 'ao']:
                a = t[(s, k, own, 'bvh8')]; b = t[(s, k, et, 'bvh8')]; e = t[(s, k, own, 'embree')]
                rat = lambda x, y: statistics.median(ys / xs for xs, ys in zip(x['round_seconds'], y['round_seconds']))
                print(f"| {s} | {k} | {rat(a, e):.3f} | {rat(b, e):.3f} | {rat(a, b):.3f} | {a['triangles_per_ray']:.2f} / {b['triangles_per_ray']:.2f} |")
