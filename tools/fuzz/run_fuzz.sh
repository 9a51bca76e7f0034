#!/usr/bin/env bash
# Builds a libFuzzer target (clang, ASan + UBSan) and runs it from the
# repository root on a corpus seeded from the test data.
#   tools/fuzz/run_fuzz.sh [SECONDS] [LIB_BUILD_DIR] [TARGET]
#   (default 120 s, build, gltf)
# TARGET: gltf (the glTF loader, .gltf and .glb), spd (the SPD/CSV reader),
# checkpoint (the checkpoint reader), cli (the render command line).
# Crashing inputs land in fuzz-out/TARGET/ (crash-*, leak-*, timeout-*, oom-*);
# copy each one that reproduces into the regression folder of its target:
# tests/data/gltf/regress/ (loaded by test_gltf) or tests/data/fuzz/TARGET/
# (run by test_harden). The last lines give libFuzzer's figures: executions
# (stat::number_of_executed_units) and coverage (cov: edges, ft: features).
# Needs: clang, libclang-rt-14-dev (apt-get install clang libclang-rt-14-dev).
set -eu
cd "$(dirname "$0")/../.."
secs=${1:-120}
lib=${2:-build}
target=${3:-gltf}
out=fuzz-out/$target
mkdir -p "$out/obj" "$out/corpus"
make -s BUILD="$lib" "$lib/libspectrace.a"
san="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -g -O1"
flags="-Isrc -Ikernels -I$lib/gen -D_GNU_SOURCE -DCL_TARGET_OPENCL_VERSION=120 $(pkg-config --cflags OpenEXR)"
# The sources each target exercises, built instrumented; the library supplies
# the rest uninstrumented (whole object files are replaced, so no symbol is
# defined twice).
case $target in
  gltf) srcs="$(ls src/scene/gltf_*.cpp) src/io/texture_io.cpp src/scene/mesh_decode.cpp src/scene/scene.c"
        dict=-dict=tools/fuzz/gltf.dict; max_len=65536
        cp -n tests/data/gltf/*.gltf tests/data/gltf/*.glb tests/data/gltf/regress/* "$out/corpus/" 2>/dev/null || true ;;
  spd)  srcs="src/color/spd.c"; dict=; max_len=4096
        cp -n tests/data/colour/colorchecker/*.csv tests/data/colour/efficacy.csv "$out/corpus/" 2>/dev/null || true ;;
  checkpoint)
        srcs="src/render/checkpoint.c src/io/exr.c src/render/film.c"; dict=; max_len=65536
        # Seeds: checkpoints of a tiny render (needs an OpenCL device).
        if [ -x "$lib/spectrace" ] && [ ! -e "$out/corpus/seed_ck.exr" ]; then
          "$lib/spectrace" render tests/data/scenes/furnace.gltf --width 4 --height 3 --spp 4 -q \
            -o "$out/seed.exr" --checkpoint "$out/corpus/seed_ck.exr" || true
          cp "$out/seed.exr" "$out/corpus/" 2>/dev/null || true
        fi ;;
  cli)  srcs="src/api/render_args.c src/io/atomic_file.c"; dict=; max_len=1024
        printf 'scene.gltf\n--spp\n64\n-o\nout.exr\n' > "$out/corpus/seed1"
        printf -- '--width\n640\n--height\n480\n--time\n2.5\n--seed\n7\nx.glb\n' > "$out/corpus/seed2"
        printf -- '--env\nsky.hdr\n--env-rotation\n-90\n--tonemap\nneutral\n-q\n--exposure\n-2\ns.gltf\n' > "$out/corpus/seed3" ;;
  *) echo "unknown target '$target' (gltf, spd, checkpoint, cli)" >&2; exit 2 ;;
esac
objs=()
for f in $srcs; do
  o="$out/obj/$(basename "${f%.*}").o"
  case $f in
    *.cpp) clang++ -std=c++17 $san $flags -I/usr/include/nlohmann -I/usr/include/stb -c "$f" -o "$o" ;;
    *)     clang -std=c11 $san $flags -c "$f" -o "$o" ;;
  esac
  objs+=("$o")
done
clang -std=c11 $san $flags -c "tools/fuzz/fuzz_$target.c" -o "$out/obj/fuzz_$target.o"
clang++ -fsanitize=fuzzer,address,undefined -o "$out/fuzz_$target" "$out/obj/fuzz_$target.o" \
  "${objs[@]}" "$lib/libspectrace.a" \
  $(pkg-config --libs tinygltf OpenImageIO OpenCL OpenEXR draco) -lmeshoptimizer -lm -lpthread
# One process (no -jobs: that forks and logs to fuzz-N.log); stdout and stderr closed (the
# readers' warnings are noise: reproduce a crash with "$out/fuzz_$target FILE").
"$out/fuzz_$target" "$out/corpus" $dict -max_total_time="$secs" \
  -timeout=10 -rss_limit_mb=2048 -max_len=$max_len -close_fd_mask=3 -artifact_prefix="$out/" \
  -print_final_stats=1 2>&1 | tail -20 || true
ls "$out"/crash-* "$out"/leak-* "$out"/timeout-* "$out"/oom-* 2>/dev/null || echo "no crashing inputs"
