#!/usr/bin/env bash
# Runs every test binary in BUILD/tests from the source root on PoCL, then the
# device-facing tests (those that run kernels) once more on PoCL with the
# kernels' GPU code path (pocl-gpu: SPECTRACE_KERNEL_PATH=gpu, the path GPUs
# take, src/render/wavefront.c), and on each other OpenCL implementation that
# tools/install_opencl.sh installed: rusticl (Mesa, llvmpipe) and intel (Intel's
# CPU runtime). Each implementation is made the only one a test
# sees through OCL_ICD_VENDORS (tools/opencl_env.sh; nothing under /etc is used),
# and SPECTRACE_TEST_IMPL names it to the tests. One line per implementation gives
# its counts of cmocka test cases, an absent one says why, and the last line sums
# them: "all: N passed, N failed, N skipped". A binary that crashes or exits
# non-zero without reporting counts as one failed case. Exit status: 0 only when
# nothing failed.
# Usage: tests/run_tests.sh BUILD_DIR [TEST_NAME...]
# SPECTRACE_TEST_IMPLS: the implementations to run, "all" (the default) or a comma
# list such as "pocl" or "pocl,pocl-gpu" (make test-san: the sanitizers check our host code, which is
# the same whichever implementation runs the kernels).
# SPECTRACE_TEST_FORM: "quick" (the default, make test) runs PoCL in full and the
# device tests' quick form (tests/test_util.h, test_quick) on pocl-gpu, intel and
# rusticl; "full" (make test-all, CI) runs pocl-gpu and intel in full too.
# rusticl runs the quick form of a subset, larger in the full run (below).
# Each binary's line ends with its wall time and the CPU time (user + system) of
# its processes: on a shared machine the CPU time is the steadier figure.
set -u
build=${1:?usage: tests/run_tests.sh BUILD_DIR [TEST_NAME...]}
shift
cd "$(dirname "$0")/.."
# Our program cache in the build folder, so tests never touch the user's cache.
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
export SPECTRACE_EXE=$PWD/$build/spectrace
# Sanitizer builds: PoCL and LLVM never free their compiler state, which
# LeakSanitizer reports at exit after a cold kernel compile; tests/lsan.supp
# suppresses leaks inside those libraries only (ours stay visible).
# use_tls=0: LeakSanitizer's scan of the main thread's dynamic TLS crashed
# ("Tracer caught signal 11" on a DTLS entry at a bogus address) at the exit
# of some runs; the allocations then rooted only in TLS are the C library's
# and GLib's (tests/lsan.supp).
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0:use_tls=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}
# The MPI tests run mpirun; as root in CI Open MPI needs these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

# The tests that run our kernels, and so run on every implementation. The others
# (loaders, image output, the command line, MPI) test host code only, or PoCL's
# device split (test_cl), and run on PoCL alone.
device_tests=(test_bsdf test_anisotropy test_bvh test_lights test_materials test_render test_render_sky test_shading test_caustics test_caustics_ref test_prism
              test_caustics_sky test_hostile_spot test_hostile_spectra test_hostile_radiance
              test_rng test_sampling test_textures test_multidevice test_checkpoint test_sweep test_aov
              test_spectral test_adaptive test_wavelength test_kernel_headers test_api test_frames
              test_iridescence test_light_tree test_instancing test_caustics_merge test_instance_render
              test_gltf_instances)

if [ $# -gt 0 ]; then
  names=("$@")
else
  names=(); for b in "$build"/tests/test_*; do names+=("$(basename "$b")"); done
fi

form=${SPECTRACE_TEST_FORM:-quick}
case "$form" in quick|full) ;; *) echo "SPECTRACE_TEST_FORM: quick or full, not '$form'" >&2; exit 2 ;; esac
impls=${SPECTRACE_TEST_IMPLS:-all}
[ "$impls" = all ] && impls=pocl,pocl-gpu,rusticl,intel
IFS=, read -r -a impl_list <<<"$impls"

# rusticl (Mesa 22.3's, on llvmpipe) spends about 10 ms of its own time per
# kernel launch here (a 64x64 Cornell box at 4 spp takes 25 s), so it runs a
# subset: it builds the same program and runs the GPU path's kernels in each of
# these, while pocl-gpu runs every device test on that path. The full form adds
# the two that render most there (quick form, 2 cores: test_textures 342 s and
# test_multidevice 173 s of CPU time, the other six 67 s together).
# The tests of instancing, the light tree and photon merging run in their
# rusticl form (tests/test_util.h, test_on_rusticl; test_kernel_path_here: the
# GPU path only, smaller renders). What rusticl costs is its cold build of
# each program variant (the build options, src/render/wavefront.c): CI starts
# with Mesa's shader cache empty, and llvmpipe compiles a kernel at its first
# launch, most of it in LLVM's coroutine splitting (CoroSplit: gallivm makes
# each compute shader a coroutine, for barriers, and splits it whatever
# GALLIVM_PERF says), whose cost grows faster than the kernel: with the
# camera and light paths' shading in two kernels (k_shade, k_shade_light;
# docs/performance.md "rusticl's build") test_sweep, which builds the GPU
# path's program without options first, took 167 s of CPU (230 s wall) with
# the caches empty, against 483 s with the shading in one kernel. The tests
# of instancing and the light tree build only that variant: the build is
# paid once, and they add their times with the cache warm:
# test_gltf_instances 58 s, test_instance_render 29 s (and 81 s of wall time
# for its instanced emitters' test), test_light_tree 103 s of CPU.
# test_caustics_merge builds the -DSPT_MERGE=1 program, a second cold build
# (213 s of CPU, 2.0 GB), then runs its spot caustic and split invariance at
# 24 x 24 in 86 s (131 s of CPU) with the cache warm. Left out: test_api
# (with the cache warm, its first 5 of 18 tests took 420 s here: its renders
# are sized for PoCL).
rusticl_subset=(test_bsdf test_bvh test_caustics_merge test_gltf_instances test_instance_render test_instancing
                test_light_tree test_lights test_rng test_sampling test_sweep test_wavelength)
[ "$form" = full ] && rusticl_subset+=(test_textures test_multidevice)
# test_multidevice and test_sweep split one render across PoCL and another
# implementation; pocl-gpu is PoCL itself.
pocl_gpu_left_out=(test_multidevice test_sweep)

# The user + system CPU seconds of this shell's finished children, into the
# variable named $1 (bash's times, run in this shell: a subshell has its own).
cpu_file=$(mktemp); trap 'rm -f "$cpu_file"' EXIT
children_cpu() {
  times >"$cpu_file"
  printf -v "$1" '%s' "$(awk 'NR == 2 {
    for (i = 1; i <= 2; i++) { split($i, t, /[ms]/); s += t[1] * 60 + t[2] }
    printf "%d", s + 0.5 }' "$cpu_file")"
}

total_p=0; total_f=0; total_s=0; summary=(); failed_bins=()
for impl in "${impl_list[@]}"; do
  # pocl runs every test; the others the device-facing ones, and test_multidevice
  # and test_sweep across PoCL and themselves (one image from two implementations).
  bins=(); summary_left=()
  for n in "${names[@]}"; do
    if [ "$impl" = pocl ] || [[ " ${device_tests[*]} " == *" $n "* ]]; then
      if [ "$impl" = rusticl ] && [ $# -eq 0 ] && [[ " ${rusticl_subset[*]} " != *" $n "* ]]; then
        summary_left+=("$n"); continue
      fi
      [ "$impl" = pocl-gpu ] && [[ " ${pocl_gpu_left_out[*]} " == *" $n "* ]] && continue
      bins+=("$n")
    fi
  done
  [ ${#bins[@]} -eq 0 ] && continue
  base=$impl; [ "$impl" = pocl-gpu ] && base=pocl
  if ! envs=$(tools/opencl_env.sh "$base" "$PWD/$build/icd/$base" 2>&1); then
    summary+=("$impl: absent ($envs)")
    if [ "$base" = pocl ]; then total_f=$((total_f + 1)); failed_bins+=("$impl"); fi
    continue
  fi
  mixed=""; [ "$base" != pocl ] && mixed=$(tools/opencl_env.sh "pocl,$impl" "$PWD/$build/icd/pocl+$impl" 2>/dev/null)
  p_sum=0; f_sum=0; s_sum=0; impl_start=$(date +%s); children_cpu impl_cpu_start
  for name in "${bins[@]}"; do
    bin=$build/tests/$name
    [ -x "$bin" ] || continue
    env_here=$envs
    [ "$impl" = pocl-gpu ] && env_here="$envs
export SPECTRACE_KERNEL_PATH=gpu"
    [ "$impl" != pocl ] && { [ "$name" = test_multidevice ] || [ "$name" = test_sweep ]; } && [ -n "$mixed" ] && env_here=$mixed
    echo "== $name ($impl)"
    log=$(mktemp)
    start=$(date +%s)
    children_cpu cpu_start
    # PoCL runs the full form; rusticl, at about 10 ms per kernel launch here,
    # always the quick form; the others the quick form unless the run is "full".
    quick=0
    if [ "$impl" = rusticl ] || { [ "$impl" != pocl ] && [ "$form" = quick ]; }; then quick=1; fi
    (eval "$env_here"; export SPECTRACE_TEST_IMPL=$impl SPECTRACE_TEST_QUICK=$quick; exec "$bin") 2>&1 |
      tee "$log"
    rc=${PIPESTATUS[0]}
    p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
    f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
    s=$(sed -n 's/^\[  SKIPPED \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
    children_cpu cpu_end
    echo "== $name ($impl): $p passed, $f failed, $s skipped ($(( $(date +%s) - start )) s, CPU $((cpu_end - cpu_start)) s)"
    p_sum=$((p_sum + p)); f_sum=$((f_sum + f)); s_sum=$((s_sum + s))
    [ "$f" -gt 0 ] && failed_bins+=("$name($impl)")
    rm -f "$log"
  done
  left=""; [ "$impl" = rusticl ] && [ ${#summary_left[@]} -gt 0 ] && left=" (left out there: ${summary_left[*]})"
  children_cpu impl_cpu_end
  summary+=("$impl: $p_sum passed, $f_sum failed, $s_sum skipped$left ($(( $(date +%s) - impl_start )) s, CPU $((impl_cpu_end - impl_cpu_start)) s)")
  total_p=$((total_p + p_sum)); total_f=$((total_f + f_sum)); total_s=$((total_s + s_sum))
done
echo
[ ${#failed_bins[@]} -gt 0 ] && echo "failing: ${failed_bins[*]}"
for line in "${summary[@]}"; do echo "$line"; done
echo "all: $total_p passed, $total_f failed, $total_s skipped"
[ "$total_f" -eq 0 ]
