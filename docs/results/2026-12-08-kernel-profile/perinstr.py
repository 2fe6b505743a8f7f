import sys,collections,re
fn=sys.argv[1]
cost=collections.Counter()
addr=0; line=0; skip=False
for l in open(fn):
    l=l.rstrip('\n')
    if l.startswith('calls='): skip=True; continue
    if not l or not (l[0] in '0123456789+-*'): 
        continue
    parts=l.split()
    def upd(tok,prev):
        if tok=='*': return prev
        if tok.startswith('+'): return prev+int(tok[1:],0)
        if tok.startswith('-'): return prev-int(tok[1:],0)
        return int(tok,0)
    a=upd(parts[0],addr); ln=upd(parts[1],line) if len(parts)>1 else line
    if skip:
        skip=False; addr=a; line=ln; continue
    addr=a; line=ln
    if len(parts)>2: cost[a]+=int(parts[2])
for a,c in sorted(cost.items()):
    print(hex(a),c)
