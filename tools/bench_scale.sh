#!/usr/bin/env bash
# `make bench`, scale block (issue "Scale"): paths per second of the Cornell box
# (256x256, 64 spp, max depth 8) rendered by build/spectrace on
#   A: one PoCL device of two compute units   (POCL_DEVICES=pthread, 2 threads)
#   B: two PoCL devices of one compute unit   (POCL_DEVICES="pthread pthread", --device all)
#   B2: the same two devices sharing two threads (POCL_MAX_PTHREAD_COUNT=2)
#   C: one process, one compute unit
#   D: mpirun -n 2 build/spectrace-mpi, one compute unit per rank
# and the ratios B/A (target >= 0.9) and D/C (target >= 1.8), medians of RUNS runs.
# PoCL 3.1's pthread devices share one scheduler: POCL_MAX_PTHREAD_COUNT threads
# serve every pthread device of the process, so in B the two "one compute unit"
# devices take turns on ONE thread and B can only match C. B2 gives the pool two
# threads, which is what two devices on a 2-core machine can really have; B2/A
# is the cost of splitting one image over two devices.
# Paths per second are the program's own figure: camera paths over the wall time
# of the render (program load from the cache and, for MPI, the other rank's scene
# set-up included; process start not).
# Usage: tools/bench_scale.sh BUILD_DIR [RUNS]
set -u
build=${1:-build}
runs=${2:-${SPECTRACE_BENCH_SCALE_RUNS:-3}}
cd "$(dirname "$0")/.."
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
args=(render scenes/cornell_box.gltf --width 256 --height 256 --spp 64 --max-depth 8 --seed 1
      -o "$tmp/out.exr")

# Mpaths/s of one run: the "rendered ..." line's figure.
mpaths() {
  "$@" 2>&1 | sed -n 's/^rendered .*(\([0-9.]*\) Mpaths\/s.*/\1/p' | tail -1
}

# Median Mpaths/s of $runs runs of the command (after a 1-spp warm-up run,
# which fills the program caches).
median_of() {
  mpaths "$@" --spp 1 >/dev/null
  local v=()
  for ((i = 0; i < runs; i++)); do v+=("$(mpaths "$@")"); done
  printf '%s\n' "${v[@]}" | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'
}

status=0
echo "load average before: $(cut -d" " -f1-3 /proc/loadavg) (other work on the machine skews these figures)"
a=$(POCL_DEVICES=pthread POCL_MAX_PTHREAD_COUNT=2 median_of "$build/spectrace" "${args[@]}" --device 0)
b=$(POCL_DEVICES="pthread pthread" POCL_MAX_PTHREAD_COUNT=1 median_of "$build/spectrace" "${args[@]}" --device all)
b2=$(POCL_DEVICES="pthread pthread" POCL_MAX_PTHREAD_COUNT=2 median_of "$build/spectrace" "${args[@]}" --device all)
echo "A one device, 2 compute units:     $a Mpaths/s (median of $runs)"
echo "B two devices, 1 compute unit each: $b Mpaths/s (PoCL runs both on one shared thread)"
echo "B2 two devices, 2 shared threads:  $b2 Mpaths/s"
awk -v a="$a" -v b="$b" 'BEGIN {r = a > 0 ? b / a : 0; printf "B/A = %.3f (target >= 0.9)%s\n", r, (r >= 0.9 ? "" : "  BELOW TARGET")}'
awk -v a="$a" -v b="$b2" 'BEGIN {r = a > 0 ? b / a : 0; printf "B2/A = %.3f (target >= 0.9)%s\n", r, (r >= 0.9 ? "" : "  BELOW TARGET")}'

if [ -x "$build/spectrace-mpi" ] && command -v mpirun >/dev/null 2>&1; then
  c=$(POCL_DEVICES=pthread POCL_MAX_PTHREAD_COUNT=1 median_of "$build/spectrace" "${args[@]}" --device 0)
  d=$(POCL_DEVICES=pthread POCL_MAX_PTHREAD_COUNT=1 median_of mpirun --oversubscribe -n 2 \
        "$build/spectrace-mpi" "${args[@]}" --device 0)
  echo "C one process, 1 compute unit:     $c Mpaths/s"
  echo "D mpirun -n 2, 1 compute unit each: $d Mpaths/s"
  awk -v c="$c" -v d="$d" 'BEGIN {r = c > 0 ? d / c : 0; printf "D/C = %.3f (target >= 1.8)%s\n", r, (r >= 1.8 ? "" : "  BELOW TARGET")}'
else
  echo "MPI: skipped ($build/spectrace-mpi or mpirun missing: make mpi)"
fi
echo "load average after: $(cut -d" " -f1-3 /proc/loadavg)"
exit $status
