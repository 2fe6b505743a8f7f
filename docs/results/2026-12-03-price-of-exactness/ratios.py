import collections, statistics, sys
rows=collections.defaultdict(lambda: collections.defaultdict(dict))
work={}
for l in open(sys.argv[1]):
    p=l.split()
    if len(p)<6 or p[4]!='mrays': continue
    s,k,r,kern=p[0],p[1],int(p[2]),p[3]
    rows[(s,k)][r][kern]=float(p[5])
    work[(s,k,kern)]=(p[11],p[13],p[15])
print("| scene | rays | exact Mrays/s | inexact Mrays/s | inexact / exact (median of rounds, range) | work per ray exact (inner, leaves, tris) |")
print("|---|---|---:|---:|---:|---|")
for (s,k),rr in rows.items():
    ex=[rr[r]['exact'] for r in sorted(rr)]; ix=[rr[r]['inexact'] for r in sorted(rr)]
    rat=[rr[r]['inexact']/rr[r]['exact'] for r in sorted(rr)]
    w=work[(s,k,'exact')]
    print(f"| {s} | {k} | {statistics.median(ex):.2f} | {statistics.median(ix):.2f} | {statistics.median(rat):.3f} ({min(rat):.3f}–{max(rat):.3f}) | {', '.join(w)} |")
