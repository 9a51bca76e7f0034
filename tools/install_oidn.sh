#!/usr/bin/env bash
# Installs Intel Open Image Denoise 2 for `spectrace render --denoise`: the
# shared libraries of the PyPI package pyoidn (the CPU device, the CUDA device
# and TBB) into deps/oidn/lib/ of the project (ignored by git), not
# system-wide; src/io/denoise.c loads them from there at run time. Idempotent:
# does nothing when that version is in place. pip (python3 -m pip) downloads
# the wheel; without pip, tools/install_deps.sh installs Debian's python3-pip.
# Usage: tools/install_oidn.sh [--optional]   (--optional: a failure is a note,
# exit status 0, as `make test` runs it; its --denoise tests then skip)
set -u
cd "$(dirname "$0")/.."
version=2.5.1.0
dest=deps/oidn
optional=0; [ "${1:-}" = --optional ] && optional=1

fail() {
  if [ $optional = 1 ]; then
    echo "note: install_oidn.sh: $* (the --denoise tests will be skipped)" >&2; exit 0
  fi
  echo "error: install_oidn.sh: $*" >&2; exit 3
}

[ -f "$dest/VERSION" ] && [ "$(cat "$dest/VERSION")" = "$version" ] && \
  [ -e "$dest/lib/libOpenImageDenoise.so.2" ] && exit 0
command -v python3 >/dev/null 2>&1 || fail "python3 is missing (Debian: apt-get install python3 python3-pip)"
if ! python3 -m pip --version >/dev/null 2>&1; then
  tools/install_deps.sh pip || fail "python3 -m pip is missing and could not be installed"
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "install_oidn: downloading pyoidn $version from PyPI"
python3 -m pip download --quiet --no-deps --only-binary=:all: --platform manylinux2014_x86_64 \
  --python-version 3.11 -d "$tmp" "pyoidn==$version" >&2 || fail "pip could not download pyoidn $version"
wheel=$(ls "$tmp"/pyoidn-*.whl 2>/dev/null | head -1)
[ -n "$wheel" ] || fail "no pyoidn wheel downloaded"
rm -rf "$dest.new"
mkdir -p "$dest.new/lib"
# A wheel is a zip file; the libraries keep their sonames (RPATH $ORIGIN/../lib).
python3 - "$wheel" "$dest.new/lib" <<'PY' || fail "could not unpack $wheel"
import os, sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
want = ("libOpenImageDenoise.so.2", "libOpenImageDenoise_core.so.2.5.1",
        "libOpenImageDenoise_device_cpu.so.2.5.1", "libOpenImageDenoise_device_cuda.so.2.5.1",
        "libtbb.so.12")
with zipfile.ZipFile(wheel) as z:
    names = {os.path.basename(n): n for n in z.namelist() if n.startswith("pyoidn/oidn/lib/")}
    for w in want:
        with z.open(names[w]) as src, open(os.path.join(out, w), "wb") as dst:
            dst.write(src.read())
        os.chmod(os.path.join(out, w), 0o755)
PY
echo "$version" > "$dest.new/VERSION"
rm -rf "$dest"
mv "$dest.new" "$dest"
echo "install_oidn: Open Image Denoise (pyoidn $version) in $dest/lib"
