#!/usr/bin/env bash
# `make bench`, implementations: Cornell box paths/s on each OpenCL implementation
# installed (tools/install_opencl.sh), with each of the two kernel paths
# (SPECTRACE_KERNEL_PATH=cpu: paired rays and the leaf SIMD test; gpu: one ray per
# work-item), in alternated runs (every variant once per round, ROUNDS rounds), as
# medians; then each path's ratio to PoCL's default and the faster path on each
# implementation. rusticl renders a smaller image (its launches cost ~10 ms here).
# Usage: tools/bench_impls.sh BUILD_DIR [ROUNDS]
set -u
build=${1:-build}
rounds=${2:-3}
cd "$(dirname "$0")/.."
case $build in /*) ;; *) build=$PWD/$build ;; esac # absolute or relative to the root
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$build/cache}
prog=$build/spectrace

variants=()
for impl in pocl intel rusticl; do
  if env_text=$(tools/opencl_env.sh "$impl" "$build/icd/bench-$impl" 2>&1); then
    variants+=("$impl:cpu" "$impl:gpu")
  else
    echo "$impl: absent ($env_text)"
  fi
done

size_of() { [ "${1%%:*}" = rusticl ] && echo "64 --spp 4" || echo "256 --spp 16"; }

# One render; prints Mpaths/s from spectrace's "rendered WxH, N spp in T s" line.
run_one() { # IMPL:PATH
  local impl=${1%%:*} path=${1##*:} out
  out=$( (eval "$(tools/opencl_env.sh "$impl" "$build/icd/bench-$impl")"
          SPECTRACE_KERNEL_PATH=$path "$prog" render scenes/cornell_box.gltf \
            -o "$tmpdir/b.exr" --width $(size_of "$1") 2>&1) |
        sed -n 's/^rendered \([0-9]*\)x\([0-9]*\), \([0-9]*\) spp in \([0-9.]*\) s.*/\1 \2 \3 \4/p' |
        tail -1 | awk '$4 > 0 {printf "%.5f", $1 * $2 * $3 / $4 * 1e-6}')
  echo "${out:-0}"
}

tmpdir=$(mktemp -d)
trap 'rm -rf "$tmpdir"' EXIT
declare -A results
for v in "${variants[@]}"; do run_one "$v" >/dev/null; done # warm the program cache
for ((r = 0; r < rounds; r++)); do
  for v in "${variants[@]}"; do results[$v]+="$(run_one "$v") "; done
done
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
base=$(echo "${results[pocl:cpu]:-0}" | median)
printf "%-14s %-12s %14s %12s  %s\n" variant image "Mpaths/s" "/ pocl:cpu" "runs"
for v in "${variants[@]}"; do
  m=$(echo "${results[$v]}" | median)
  ratio=$(awk -v a="$m" -v b="$base" 'BEGIN {printf (b > 0 ? "%.3f" : "-"), a / b}')
  printf "%-14s %-12s %14s %12s  %s\n" "$v" "$(size_of "$v" | awk '{print $1"px "$3"spp"}')" "$m" "$ratio" "${results[$v]}"
done
for impl in pocl intel rusticl; do
  [ -n "${results[$impl:cpu]:-}" ] || continue
  c=$(echo "${results[$impl:cpu]}" | median); g=$(echo "${results[$impl:gpu]}" | median)
  awk -v i="$impl" -v c="$c" -v g="$g" 'BEGIN {printf "%s: gpu path / cpu path = %.3f (faster: %s)\n", i, (c > 0 ? g / c : 0), (g > c ? "gpu" : "cpu")}'
done
