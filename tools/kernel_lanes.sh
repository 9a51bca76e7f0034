#!/usr/bin/env bash
# How wide PoCL's machine code for the renderer's kernels is: renders a small
# image with PoCL keeping its compiler's files, disassembles each kernel's
# shared object and counts, per function of at least 100 instructions, the
# floating-point arithmetic by width: scalar (ss), and packed in xmm (4
# lanes), ymm (8) and zmm (16) registers (docs/performance.md, "Vector
# width"). Moves, shuffles and compares of integers are left out.
# Usage: tools/kernel_lanes.sh BUILD_DIR [KERNEL...]   (default: k_paths)
# PoCL's target follows the host; POCL_KERNELLIB_NAME=avx2 (or avx512, sse41)
# makes it compile for that instead (the device is then named pthread-haswell).
set -eu
build=${1:-build}
shift || true
kernels=${*:-k_paths}
cd "$(dirname "$0")/.."
tmp=$(mktemp -d /tmp/spt_lanes.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1 POCL_CACHE_DIR="$tmp/pocl" SPECTRACE_CACHE_DIR=off \
    "$build/spectrace" render scenes/cornell_box.gltf -o "$tmp/o.exr" --width 32 --height 32 \
    --spp 1 --max-depth 8 2>&1 | grep '^device 0:' | grep -v building || true
for k in $kernels; do
    so=$(find "$tmp/pocl" -name "$k.so" | head -n 1)
    if [ -z "$so" ]; then
        echo "error: $k: PoCL compiled no such kernel (its files: $tmp/pocl)" >&2
        exit 1
    fi
    echo "== $k"
    printf "%-40s %7s %7s %7s %7s %7s\n" function insns scalar 4-lane 8-lane 16-lane
    objdump -d --no-show-raw-insn "$so" | awk '
        /^[0-9a-f]+ </ { fn = $2; gsub(/[<>:]/, "", fn); next }
        /^ +[0-9a-f]+:/ {
            n[fn]++
            line = $0; sub(/^ +[0-9a-f]+:\t/, "", line)
            op = line; sub(/[ \t].*/, "", op)
            # floating-point arithmetic only: not moves, shuffles, blends, converts
            if (op ~ /^v?(mov|shuf|perm|blend|insert|extract|broadcast|unpck|cvt|gather|and|or|xor|comi|ucomi)/) next
            if (op ~ /ss$/) s[fn]++
            else if (op ~ /ps$/) {
                if (line ~ /zmm/) z[fn]++
                else if (line ~ /ymm/) y[fn]++
                else x[fn]++
            }
        }
        END {
            for (f in n) if (n[f] >= 100)
                printf "%-40s %7d %7d %7d %7d %7d\n", f, n[f], s[f], x[f], y[f], z[f]
        }' | sort -k2 -n -r
done
