#!/usr/bin/env bash
# Renders every glTF scene under scenes/ and tests/data (except the bad_* files
# made to be refused) small, on PoCL's CPU path and its GPU path
# (SPECTRACE_KERNEL_PATH=gpu), and prints one line per render: the scene, the
# path, the exit status and a hash of the EXR with its render-time attribute
# zeroed (the only field that differs between two identical renders). Diff the
# output of two builds to show that a change leaves every image bit-identical
# (docs/testing.md "Bit-identical images").
# Usage: tools/image_hashes.sh BUILD_DIR [OUT_FILE]
set -u
build=${1:?usage: tools/image_hashes.sh BUILD_DIR [OUT_FILE]}
out=${2:-/dev/stdout}
cd "$(dirname "$0")/.."
eval "$(tools/opencl_env.sh pocl "$PWD/$build/icd/pocl")" || exit 1
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
hash_exr() { # FILE: sha256 of the EXR with spectrace:renderSeconds zeroed
  python3 - "$1" <<'PY'
import hashlib, struct, sys
b = bytearray(open(sys.argv[1], 'rb').read())
i = 8  # magic and version
while b[i] != 0:
    n = b.index(0, i); name = bytes(b[i:n]); t = b.index(0, n + 1)
    size = struct.unpack_from('<i', b, t + 1)[0]; v = t + 5
    if name == b'spectrace:renderSeconds':
        b[v:v + size] = bytes(size)
    i = v + size
print(hashlib.sha256(b).hexdigest()[:16])
PY
}
: >"$out"
find scenes tests/data \( -name '*.gltf' -o -name '*.glb' \) ! -name 'bad_*' | sort |
while read -r scene; do
  for path in cpu gpu; do
    for opts in "--spp 4" "--spp 2 --spectral 8 --aov all --caustics on"; do
      f=$tmp/img.exr; rm -f "$f"
      SPECTRACE_KERNEL_PATH=$path "$build/spectrace" render "$scene" --width 40 --height 30 \
        $opts --seed 7 -q -o "$f" >/dev/null 2>&1
      rc=$?
      h=-; [ -f "$f" ] && h=$(hash_exr "$f")
      echo "$scene $path [$opts] rc=$rc $h" >>"$out"
    done
  done
done
