import sys, math, collections
rows=[l.split('\t') for l in open('docs/results/2026-12-07-fast-build/work_per_ray.tsv').read().split('\n') if l]
w={(b,s,r):float(x) for b,s,r,x in rows}
base=sys.argv[1] if len(sys.argv)>1 else 'sweep'
builders=sorted({b for b,_,_ in w if b!=base})
for b in builders:
    out=[]
    for r in ['primary','diffuse','ao']:
        rs=[(s,w[(b,s,r)]/w[(base,s,r)]) for (bb,s,rr) in w if bb==b and rr==r and (base,s,r) in w]
        if not rs: continue
        g=math.exp(sum(math.log(x) for _,x in rs)/len(rs)); m=max(rs,key=lambda t:t[1])
        out.append(f"{r}: {g:.3f} / {m[1]:.3f} ({m[0]}) n={len(rs)}")
    print(b, ' | '.join(out))
