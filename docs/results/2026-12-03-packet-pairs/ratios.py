import sys, statistics as st, collections
d=collections.defaultdict(lambda: collections.defaultdict(dict))
chk={}
for l in open(sys.argv[1]):
    f=l.split()
    if len(f)<8: continue
    s,k,b,r,kern=f[:5]; m=float(f[6])
    d[(s,k,b)][r][kern]=m
    c=f[-1]; key=(s,k,b)
    chk.setdefault(key,set()).add(c)
print("| scene | rays | backend | base Mrays/s | pair Mrays/s | pair / base (median, range) |")
print("|---|---|---|---:|---:|---|")
allr=collections.defaultdict(list)
for key,rs in d.items():
    r=[v['pair']/v['base'] for v in rs.values() if 'pair' in v and 'base' in v]
    b=st.median(v['base'] for v in rs.values()); p=st.median(v['pair'] for v in rs.values())
    allr[(key[1],key[2])].append(st.median(r))
    print("| %s | %s | %s | %.2f | %.2f | %.3f (%.3f–%.3f) |%s"%(key[0],key[1],key[2],b,p,st.median(r),min(r),max(r), "" if len(chk[key])==1 else " CHECKSUM DIFFERS"))
import math
print()
for k,v in sorted(allr.items()):
    print("geomean %s %s: %.3f (min %.3f max %.3f)"%(k[0],k[1],math.exp(sum(map(math.log,v))/len(v)),min(v),max(v)))
