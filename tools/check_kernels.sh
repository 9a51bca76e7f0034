#!/usr/bin/env bash
# `make check-kernels`: renders the test scenes (8x8 pixels, 2 samples; every
# material, texture, alpha mode, volume, light type, the environment map, the
# thin lens and the orthographic camera) under Oclgrind, the OpenCL simulator,
# with --data-races and --check-api, on both code paths of the kernels: the GPU
# path (Oclgrind is a GPU to spectrace) and the CPU path (SPECTRACE_KERNEL_PATH=cpu:
# whole paths in k_paths, paired rays and the leaf SIMD test), and the Cornell
# box's two runs on the CPU path in the stage kernels (cpu-stages). Fails on any report of Oclgrind's (invalid
# memory access, data race, API misuse, ...) and on any failed render.
# Oclgrind needs -cl-opt-disable: its interpreter lacks llvm.bitreverse.i32,
# which clang's optimiser makes of our Sobol bit reversal.
# Usage: tools/check_kernels.sh [BUILD_DIR] [EXTRA_OCLGRIND_OPTION...]
#   e.g. tools/check_kernels.sh build --uninitialized
set -u
build=${1:-build}
shift || true
cd "$(dirname "$0")/.."
prog=$build/spectrace
if ! command -v oclgrind >/dev/null 2>&1; then
  why="not installed (Debian: apt-get install oclgrind; make deps installs it)"
  [ -f deps/oclgrind.absent ] && why=$(cat deps/oclgrind.absent)
  echo "error: check-kernels: oclgrind: $why" >&2
  exit 2
fi
[ -x "$prog" ] || { echo "error: check-kernels: $prog is not built" >&2; exit 2; }

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# No program cache (Oclgrind's binaries are its own), a small path pool (the
# simulator runs every work-item of it on each iteration).
export SPECTRACE_CACHE_DIR=off SPECTRACE_POOL=64

# An environment map for --env: a small render of the furnace (grey, so no
# negative sRGB values) on the default device, not under Oclgrind.
if ! "$prog" render tests/data/scenes/furnace_spectral.gltf -o "$tmp/env.exr" --width 16 --height 8 --spp 1 -q \
     >"$tmp/env.log" 2>&1; then
  echo "error: check-kernels: could not render the environment map:" >&2
  cat "$tmp/env.log" >&2
  exit 1
fi

runs=(
  "scenes/cornell_box.gltf"
  "scenes/cornell_box.gltf --aperture 0.05 --max-depth 4"
  "scenes/cornell_box.gltf --env $tmp/env.exr"
  "tests/data/scenes/cornell_box_rgb.gltf --background 0.2,0.3,0.5"
  "tests/data/scenes/furnace.gltf"
  "tests/data/scenes/furnace_spectral.gltf"
  "tests/data/scenes/plane_irradiance.gltf"
  "tests/data/scenes/mat_conductor.gltf"
  "tests/data/scenes/mat_roughconductor.gltf"
  "tests/data/scenes/mat_dielectric.gltf"
  "tests/data/scenes/mat_roughdielectric.gltf"
  "tests/data/scenes/mat_furnace_roughglass.gltf"
  "tests/data/scenes/mat_point_light.gltf"
  "tests/data/gltf/lights.gltf"
  "tests/data/gltf/materials.gltf"
  "tests/data/gltf/ortho.gltf"
  "tests/data/gltf/wild_texture_transform.gltf"
  "tests/data/gltf/wild_specgloss.gltf"
)
failed=0; n=0
for path in gpu cpu cpu-stages; do
  k=0
  for run in "${runs[@]}"; do
    k=$((k + 1))
    [ "$path" = cpu-stages ] && [ "$k" -gt 2 ] && continue
    n=$((n + 1))
    read -r -a args <<<"$run"
    log=$tmp/oclgrind_$n.log
    start=$(date +%s)
    SPECTRACE_KERNEL_PATH=$path oclgrind --data-races --check-api --max-errors 20 \
      --build-options "-cl-opt-disable" --log "$log" "$@" \
      "$prog" render "${args[@]}" -o "$tmp/out.exr" --width 8 --height 8 --spp 2 -q \
      >"$tmp/out.log" 2>&1
    rc=$?
    secs=$(( $(date +%s) - start ))
    if [ "$rc" -ne 0 ] || [ -s "$log" ]; then
      failed=$((failed + 1))
      echo "FAIL $path path: ${args[*]} (exit $rc, ${secs} s)"
      cat "$tmp/out.log"
      [ -s "$log" ] && head -c 20000 "$log"
    else
      echo "ok   $path path: ${args[*]} (${secs} s)"
    fi
  done
done
echo "check-kernels: $((n - failed)) passed, $failed failed"
[ "$failed" -eq 0 ]
