"""Reads `llvm-cov show` text output and lists, per file, every line containing `unsafe`
and every test of a parallel threshold, with its execution count; unreached ones are marked.
The count of a threshold test's line is how often it was evaluated; the count of the next
lines (the parallel branch) says whether the threshold was crossed."""
import re
import sys

THRESHOLDS = re.compile(
    r"PAR_NODE_THRESHOLD|PAR_SORT_THRESHOLD|PAR_PARTITION_THRESHOLD|PAR_AXES_THRESHOLD|"
    r"PARALLEL_THRESHOLD|HUGE_THRESHOLD|par_nodes|par_refs|plan_nodes|RADIX_MIN|>= huge|bytes >= ")
LINE = re.compile(r"^\s*(\d+)\|\s*([0-9.]+[kMGE]?)?\|(.*)$")


def count(text):
    if text is None:
        return None
    mult = {"k": 1e3, "M": 1e6, "G": 1e9, "E": 1e18}
    if text[-1] in mult:
        return float(text[:-1]) * mult[text[-1]]
    return float(text)


files = {}
current = None
for raw in open(sys.argv[1], encoding="utf-8", errors="replace"):
    raw = raw.rstrip("\n")
    if raw.endswith(".rs:") and "|" not in raw:
        current = raw[:-1]
        files[current] = []
        continue
    m = LINE.match(raw)
    if m and current:
        files[current].append((int(m.group(1)), m.group(2), m.group(3)))

print("# Unsafe lines and parallel thresholds reached by the corpus\n")
print("`count` is the line's execution count (`-`: no code on the line, e.g. a signature "
      "whose count is on the next line); `NOT REACHED` marks a zero.\n")
total = reached = 0
for path in sorted(files):
    rows = files[path]
    # A trait's method declaration (`unsafe fn f(..) -> T;`) has no code: left out.
    unsafe = [(n, c, s) for n, c, s in rows if re.search(r"\bunsafe\b", s)
              and not s.strip().startswith("//") and not s.rstrip().endswith(";")
              or re.search(r"\bunsafe\b", s) and c is not None and not s.strip().startswith("//")]
    thresh = [(i, n, c, s) for i, (n, c, s) in enumerate(rows) if THRESHOLDS.search(s)
              and not s.strip().startswith("//") and not s.strip().startswith("const ")
              and not s.strip().startswith("pub const ") and "use " not in s]
    if not unsafe and not thresh:
        continue
    print(f"## {path}\n")
    if unsafe:
        print("| line | count | unsafe |\n|---:|---:|---|")
        for n, c, s in unsafe:
            # An `unsafe fn` signature has no count of its own: take the next counted line.
            shown = c
            if c is None:
                nxt = [cc for nn, cc, _ in rows if nn > n and cc is not None]
                shown = nxt[0] if nxt else None
            mark = "" if shown is None or count(shown) > 0 else " NOT REACHED"
            if shown is not None:
                total += 1
                reached += count(shown) > 0
            print(f"| {n} | {shown if shown is not None else '-'}{mark} | `{s.strip()[:90]}` |")
        print()
    if thresh:
        print("| line | test count | next lines' counts | threshold test |\n|---:|---:|---|---|")
        for i, n, c, s in thresh:
            after = ", ".join(cc or "-" for _, cc, _ in rows[i + 1:i + 4])
            print(f"| {n} | {c or '-'} | {after} | `{s.strip()[:90]}` |")
        print()
print(f"Unsafe lines with code: {reached} of {total} reached.")
