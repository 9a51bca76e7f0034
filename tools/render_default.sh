#!/usr/bin/env bash
# `make render`: renders the default scene (scenes/cornell_box.gltf) into out/.
set -eu
prog=${1:-build/spectrace}
mkdir -p out
"$prog" render scenes/cornell_box.gltf -o out/cornell_box.exr -o out/cornell_box.png --width 512 --spp 64 "${@:2}"
echo "make render: the images are out/cornell_box.exr (linear HDR) and out/cornell_box.png (sRGB)" >&2
