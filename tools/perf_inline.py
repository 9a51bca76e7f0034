#!/usr/bin/env python3
"""perf's samples of one kernel by the function each sampled instruction was
inlined from (docs/performance.md, "Instructions per segment").

PoCL inlines most of a kernel into a few functions, so `perf report --sort
sym` puts the shading's whole time on shade_path. This reads `perf script`'s
samples of a kernel's shared object, asks llvm-symbolizer for each sampled
address's inline chain, and sums the samples by the chain's first DEPTH
frames below FUNCTION (the outermost functions inlined into it); samples in
other functions count under their own name in brackets. Percentages are of
all the object's samples.

The object must carry debug information and be the one perf sampled:

  SPECTRACE_CACHE_DIR=off POCL_CACHE_DIR=/tmp/pc POCL_EXTRA_BUILD_FLAGS=-g \\
      perf record -F 2000 -o perf.data build/spectrace render ...
  tools/perf_inline.py perf.data $(find /tmp/pc -name k_paths.so) shade_path_kept [DEPTH]

(a first small render builds the program into /tmp/pc, so that the profiled
run finds it there).
"""
import collections
import os
import shutil
import subprocess
import sys


def fail(msg):
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(1)


def main():
    if len(sys.argv) not in (4, 5):
        print(__doc__.strip().splitlines()[0], file=sys.stderr)
        print("usage: tools/perf_inline.py PERF_DATA KERNEL_SO FUNCTION [DEPTH]", file=sys.stderr)
        sys.exit(2)
    data, so, top = sys.argv[1], sys.argv[2], sys.argv[3]
    try:
        depth = int(sys.argv[4]) if len(sys.argv) == 5 else 1
    except ValueError:
        fail(f"{sys.argv[4]}: DEPTH is not a number")
    if depth < 1:
        fail(f"{depth}: DEPTH is below 1")
    for path in (data, so):
        if not os.path.isfile(path):
            fail(f"{path}: no such file")
    for tool in ("perf", "nm", "llvm-symbolizer"):
        if not shutil.which(tool):
            fail(f"{tool}: not installed")
    syms = {}
    for line in subprocess.run(["nm", so], capture_output=True, text=True).stdout.splitlines():
        f = line.split()
        if len(f) == 3:
            syms[f[2]] = int(f[0], 16)
    script = subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym,symoff,dso"],
                            capture_output=True, text=True)
    if script.returncode != 0:
        fail(f"{data}: perf script failed: {script.stderr.strip()[:200]}")
    base = os.path.basename(so)
    counts = collections.Counter()
    for line in script.stdout.splitlines():
        if f"/{base})" not in line and f"({base})" not in line:
            continue
        fields = line.split()
        if len(fields) < 3:
            continue
        symoff = fields[1]
        if "+0x" not in symoff:
            continue
        sym, off = symoff.split("+0x")
        if sym in syms:
            counts[(sym, syms[sym] + int(off, 16))] += 1
    total = sum(counts.values())
    if not total:
        fail(f"{data}: no samples in {base}")
    keys = list(counts)
    out = subprocess.run(["llvm-symbolizer", "--inlining", "--obj=" + so] + [hex(a) for _, a in keys],
                         capture_output=True, text=True).stdout
    blocks = out.strip().split("\n\n")
    if len(blocks) != len(keys):
        fail(f"{so}: llvm-symbolizer answered {len(blocks)} addresses of {len(keys)}")
    agg = collections.Counter()
    for key, block in zip(keys, blocks):
        sym, n = key[0], counts[key]
        lines = block.strip().split("\n")
        # Innermost frame first: a function name, then its file:line:column.
        frames = [(lines[i], lines[i + 1].rsplit("/", 1)[-1]) for i in range(0, len(lines) - 1, 2)]
        names = [f[0] for f in frames]
        if top not in names:
            agg[f"[{sym}]"] += n
            continue
        k = names.index(top)
        # Each frame's call site is the next outer frame's location.
        chain = [f"{frames[j][0]}@{frames[j + 1][1]}" for j in range(max(0, k - depth), k)]
        agg[" > ".join(reversed(chain)) or "(its own code)"] += n
    print(f"{total} samples in {base}; below {top}, the first {depth} inlined frame(s):")
    for chain, n in agg.most_common(40):
        print(f"{100.0 * n / total:6.2f}%  {chain}")


if __name__ == "__main__":
    main()
