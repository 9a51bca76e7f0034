#!/usr/bin/env bash
# Instructions the CPU path's kernel k_paths executes per path segment, counted
# by Valgrind's callgrind (docs/performance.md, "Instructions per segment"):
# a deterministic figure, unlike seconds on a shared machine, for comparing
# two versions of the kernels (SPECTRACE_KERNEL_DIR) to the instruction.
# Renders a scene at 128x128, 4 spp, seed 3 with PoCL compiling for AVX2
# (Valgrind 3.19 does not decode AVX-512) and counts only inside PoCL's
# k_paths work-group function; prints the instructions, the path segments of
# --profile and their ratio, and with --functions the kernel's functions.
# Usage: tools/kernel_instructions.sh BUILD_DIR [--functions] [SCENE [RENDER_ARGS...]]
#   (default scene: scenes/cornell_box.gltf; e.g. ... build scenes/cornell_box.gltf --caustics off)
set -eu
build=${1:?usage: tools/kernel_instructions.sh BUILD_DIR [--functions] [SCENE [RENDER_ARGS...]]}
shift
functions=0
if [ "${1:-}" = --functions ]; then
    functions=1
    shift
fi
scene=${1:-scenes/cornell_box.gltf}
shift || true
cd "$(dirname "$0")/.."
for t in valgrind callgrind_annotate; do
    if ! command -v "$t" >/dev/null; then
        echo "error: $t: not installed (apt-get install valgrind)" >&2
        exit 1
    fi
done
if [ ! -x "$build/spectrace" ]; then
    echo "error: $build/spectrace: no such program (make first)" >&2
    exit 1
fi
eval "$(tools/opencl_env.sh pocl "$PWD/$build/icd/pocl")"
tmp=$(mktemp -d /tmp/spt_instr.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
# PoCL's own cache, so that the counted run finds the program built.
export SPECTRACE_CACHE_DIR=off POCL_CACHE_DIR="$tmp/pocl" POCL_KERNELLIB_NAME=avx2
"$build/spectrace" render "$scene" -o "$tmp/warm.exr" --width 32 --height 32 --spp 1 -q "$@" >/dev/null 2>&1 || true
out=$(valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.out" --collect-atstart=no \
    --toggle-collect='_pocl_kernel_k_paths_workgroup*' "$build/spectrace" render "$scene" \
    -o "$tmp/o.exr" --width 128 --height 128 --spp 4 --seed 3 --profile "$@" 2>&1) || {
    echo "$out" | tail -n 5 >&2
    echo "error: $scene: the render under valgrind failed" >&2
    exit 1
}
segments=$(echo "$out" | awk '$2 == "path" && $3 == "segments," { print $1 }')
instr=$(callgrind_annotate "$tmp/cg.out" 2>/dev/null | awk '/PROGRAM TOTALS/ { gsub(",", "", $1); print $1 }')
if [ -z "$segments" ] || [ -z "$instr" ] || [ "$instr" = 0 ]; then
    echo "error: $scene: no k_paths instructions counted (the CPU kernel path did not run?)" >&2
    exit 1
fi
echo "k_paths: $instr instructions, $segments path segments, $((instr / segments)) per segment"
if [ "$functions" = 1 ]; then
    callgrind_annotate --inclusive=no --threshold=99 "$tmp/cg.out" 2>/dev/null |
        awk '/file:function/ { on = 1; next } on && NF >= 3' | sed 's/ \[[^]]*\]$//; s/???://'
fi
