#!/usr/bin/env bash
# `make bench`: the benchmarks, on the device SPECTRACE_DEVICE selects (default:
# the first GPU, else the CPU). Each block prints medians of several runs.
# Usage: tools/bench.sh BUILD_DIR
set -u
build=${1:-build}
cd "$(dirname "$0")/.."
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
status=0

# The CPU and its vector width first: ratios against Mitsuba differ between
# AVX2 and AVX-512 machines (docs/performance.md, "Vector width").
python3 tools/bench_mitsuba.py --spectrace "$build/spectrace" --machine || status=1

# ---- renderer: paths/s on the Cornell box, extend-stage rays/s on ~1M triangles ----
echo "== renderer (tools/bench_render.c)"
"$build/tools/bench_render" 3 || status=1

# ---- bvh: build speed, SAH against the full sweep, bytes/triangle, host traversal ----
echo "== bvh (tools/bench_bvh.c)"
"$build/tools/bench_bvh" 5 || status=1
# ---- end bvh ----

# ---- instances: a 20,000-triangle mesh placed 1,000 and 50,000 times (20 M and
# 1 billion triangles) as two levels, against 250 flattened: build seconds,
# bytes per level, peak memory, host rays/s, and the renderer's upload, device
# bytes and paths/s at 512x512 (tools/bench_instances.c) ----
echo "== instances (tools/bench_instances.c)"
"$build/tools/bench_instances" || status=1
# ---- end instances ----

# ---- load (wild): a generated 10M-triangle .glb in a temporary folder (removed
# after): scene_load_gltf, bvh_build and total seconds; target < 30 s on 2 cores ----
echo "== load (tools/bench_load.c)"
"$build/tools/bench_load" "${SPECTRACE_BENCH_LOAD_TRIANGLES:-10e6}" || status=1
# ---- end load ----

# ---- scale: two devices against one of twice the compute units, mpirun -n 2
# against one process (tools/bench_scale.sh) ----
echo "== scale (tools/bench_scale.sh)"
tools/bench_scale.sh "$build" || status=1
# ---- end scale ----

# ---- implementations: Cornell paths/s on each OpenCL implementation installed,
# CPU and GPU kernel paths, alternated (tools/bench_impls.sh) ----
echo "== implementations (tools/bench_impls.sh)"
tools/bench_impls.sh "$build" || status=1
# ---- end implementations ----

# ---- against Mitsuba 3: paths/s (Cornell box 512x512 64 spp, a 1M-triangle mesh
# scene at 16 spp, depth 8) and the equal-time race at 256x256 (T seconds:
# SPECTRACE_BENCH_TIME, default 20; reference SPECTRACE_BENCH_REF_SPP, default
# 4096), relMSE ratio best-Mitsuba / spectrace (tools/bench_mitsuba.py) ----
echo "== against Mitsuba 3 (tools/bench_mitsuba.py)"
python3 tools/bench_mitsuba.py --spectrace "$build/spectrace" || status=1
# ---- end against Mitsuba 3 ----

# ---- traversal against Embree: the ray queries alone on the same triangles and
# rays as Mitsuba 3's ray_intersect_preliminary and ray_test (tools/bench_trace.py) ----
echo "== traversal against Embree (tools/bench_trace.py)"
python3 tools/bench_trace.py --bench-trace "$build/tools/bench_trace" || status=1
# ---- end traversal ----
# ---- light tree: relMSE at equal time with and without it on the street of
# 1,000 lamps and the field of 200 quads (tools/bench_lights.py; T seconds:
# SPECTRACE_BENCH_TIME, default 10) ----
echo "== light tree (tools/bench_lights.py)"
python3 tools/bench_lights.py --spectrace "$build/spectrace" || status=1
# ---- end light tree ----

# ---- against Blender Cycles: the equal-time race (T seconds:
# SPECTRACE_BENCH_TIME, default 20) on the street, the field, the Cornell box,
# a glass sphere on a table and a room lit through a window, each renderer's
# relMSE against its own reference, ratios Cycles / spectrace
# (tools/bench_cycles.py; it finds bpy in SPECTRACE_BPY_PYTHON or a venv-bpy
# beside the checkout, else prints a "skip:" line) ----
echo "== against Blender Cycles (tools/bench_cycles.py)"
python3 tools/bench_cycles.py --spectrace "$build/spectrace" || status=1
# ---- end against Blender Cycles ----

exit $status
