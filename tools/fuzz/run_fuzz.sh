#!/usr/bin/env bash
# Builds the libFuzzer target for the glTF loader (clang, ASan + UBSan) and runs
# it from the repository root on a corpus seeded from tests/data/gltf.
#   tools/fuzz/run_fuzz.sh [SECONDS] [LIB_BUILD_DIR]      (default 120 s, build)
# Crashing inputs land in fuzz-out/ (crash-*, leak-*, timeout-*); copy each one
# that reproduces into tests/data/gltf/regress/ so tests/test_gltf.c loads it.
# Needs: clang, libclang-rt-14-dev (apt-get install clang libclang-rt-14-dev).
set -eu
cd "$(dirname "$0")/../.."
secs=${1:-120}
lib=${2:-build}
out=fuzz-out
mkdir -p "$out/obj" "$out/corpus"
make -s BUILD="$lib" "$lib/libspectrace.a"
san="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined -g -O1"
flags="-Isrc -Ikernels -I$lib/gen -D_GNU_SOURCE -DCL_TARGET_OPENCL_VERSION=120"
for f in src/scene/gltf_*.cpp; do
  clang++ -std=c++17 $san $flags -I/usr/include/nlohmann -c "$f" -o "$out/obj/$(basename "$f" .cpp).o"
done
clang++ -std=c++17 $san $flags -c src/scene/texture_io.cpp -o "$out/obj/texture_io.o"
clang++ -std=c++17 $san $flags -c src/scene/mesh_decode.cpp -o "$out/obj/mesh_decode.o"
clang -std=c11 $san $flags -c src/scene/scene.c -o "$out/obj/scene.o"
clang -std=c11 $san $flags -c tools/fuzz/fuzz_gltf.c -o "$out/obj/fuzz_gltf.o"
# Our instrumented objects come first; the library supplies the rest (util,
# spectrum) uninstrumented.
clang++ -fsanitize=fuzzer,address,undefined -o "$out/fuzz_gltf" "$out"/obj/*.o "$lib/libspectrace.a" \
  $(pkg-config --libs tinygltf OpenImageIO OpenCL OpenEXR draco) -lmeshoptimizer -lm -lpthread
cp -n tests/data/gltf/*.gltf tests/data/gltf/*.glb tests/data/gltf/regress/* "$out/corpus/" 2>/dev/null || true
# One process (no -jobs: that forks and logs to fuzz-N.log); stderr closed (the loader's warnings are noise:
# reproduce a crash with "$out/fuzz_gltf CRASH_FILE" to see its report).
"$out/fuzz_gltf" "$out/corpus" -dict=tools/fuzz/gltf.dict -max_total_time="$secs" \
  -timeout=10 -rss_limit_mb=2048 -max_len=65536 -close_fd_mask=2 -artifact_prefix="$out/" \
  -print_final_stats=1 2>&1 | tail -20 || true
ls "$out"/crash-* "$out"/leak-* "$out"/timeout-* "$out"/oom-* 2>/dev/null || echo "no crashing inputs"
