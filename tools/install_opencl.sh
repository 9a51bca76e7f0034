#!/usr/bin/env bash
# Installs the OpenCL implementations the tests run on besides PoCL, and Oclgrind
# (`make deps` calls it; tools/README.md describes them):
#   rusticl  Mesa's OpenCL on llvmpipe: Debian's mesa-opencl-icd, fetched with
#            apt-get download and unpacked (dpkg -x) into deps/rusticl/, its
#            library dependencies apt-get installed (installing the package itself
#            would register it in /etc/OpenCL/vendors for every program)
#   intel    Intel's OpenCL runtime for CPUs: the PyPI wheels intel-opencl-rt, its
#            undeclared intel-cmplr-lib-rt and a oneTBB newer than Debian's, unpacked
#            (pip download, no pip install) into deps/intel-ocl/ of this checkout
#   oclgrind the OpenCL simulator `make check-kernels` runs (apt-get)
# Nothing is registered under /etc: tools/opencl_env.sh gives the environment
# (OCL_ICD_VENDORS) that makes one implementation visible to a program.
# Idempotent: what is present is not fetched again. Never fails the build: an
# implementation that cannot be had leaves deps/NAME.absent with the reason, and
# the test runner prints it (e.g. without network).
# Usage: tools/install_opencl.sh [rusticl] [intel] [oclgrind]  (default: all three)
set -u
cd "$(dirname "$0")/.."
mkdir -p deps

# Pinned so that every checkout tests the same runtime; the three wheels must match
# (intel-opencl-rt declares tbb==2023.*, but not intel-cmplr-lib-rt).
INTEL_VERSION=2026.2.0
TBB_VERSION=2023.2.0

absent() { # NAME REASON...
  local name=$1; shift
  echo "$*" > "deps/$name.absent"
  echo "install_opencl: $name not installed: $*" >&2
}

apt_install() { # NAME PACKAGE
  local name=$1 pkg=$2
  if [ "$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null)" = "install ok installed" ]; then
    rm -f "deps/$name.absent"; return 0
  fi
  if ! command -v apt-get >/dev/null 2>&1; then
    absent "$name" "apt-get is not available (install Debian's $pkg)"; return 0
  fi
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then sudo="sudo -n"; else
      absent "$name" "not root and no sudo (as root: apt-get install $pkg)"; return 0
    fi
  fi
  echo "install_opencl: installing $pkg" >&2
  local log; log=$(mktemp)
  if DEBIAN_FRONTEND=noninteractive $sudo apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
       --no-install-recommends "$pkg" >"$log" 2>&1 ||
     { $sudo apt-get -o DPkg::Lock::Timeout=600 update -qq >>"$log" 2>&1 &&
       DEBIAN_FRONTEND=noninteractive $sudo apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
         --no-install-recommends "$pkg" >>"$log" 2>&1; }; then
    rm -f "deps/$name.absent"
  else
    absent "$name" "apt-get install $pkg failed: $(grep -E '^(E|W):' "$log" | head -1)"
  fi
  rm -f "$log"
}

# rusticl: mesa-opencl-icd's library under deps/rusticl (its llvmpipe driver is
# built in; the package's other files are Mesa's older clover), and the
# libraries it links installed from Debian.
install_rusticl() {
  local dir=deps/rusticl pkg=mesa-opencl-icd
  local libdir=usr/lib/x86_64-linux-gnu
  local want; want=$(apt-cache policy "$pkg" 2>/dev/null | awk '/Candidate:/ {print $2}')
  if [ -f "$dir/VERSION" ] && [ -f "$dir/$libdir/libRusticlOpenCL.so.1" ] &&
     { [ -z "$want" ] || [ "$(cat "$dir/VERSION")" = "$want" ]; }; then
    rm -f deps/rusticl.absent; return 0
  fi
  if ! command -v apt-get >/dev/null 2>&1 || ! command -v dpkg-deb >/dev/null 2>&1; then
    absent rusticl "apt-get and dpkg-deb are needed (Debian's $pkg)"; return 0
  fi
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then sudo="sudo -n"; else
      absent rusticl "not root and no sudo to install $pkg's libraries"; return 0
    fi
  fi
  echo "install_opencl: fetching $pkg into $dir" >&2
  local tmp=$dir.tmp log; log=$(mktemp)
  rm -rf "$tmp"; mkdir -p "$tmp/deb"
  if ! (cd "$tmp/deb" && apt-get download "$pkg" >"$log" 2>&1) &&
     ! { $sudo apt-get -o DPkg::Lock::Timeout=600 update -qq >>"$log" 2>&1 &&
         (cd "$tmp/deb" && apt-get download "$pkg" >>"$log" 2>&1); }; then
    absent rusticl "apt-get download $pkg failed: $(grep -E '^(E|W):' "$log" | head -1)"
    rm -f "$log"; rm -rf "$tmp"; return 0
  fi
  local deb; deb=$(ls "$tmp"/deb/*.deb | head -1)
  # Its dependencies, each the first of its alternatives, without versions.
  local deps; deps=$(dpkg-deb -f "$deb" Depends | tr ',' '\n' |
                     sed 's/|.*//; s/(.*)//; s/[[:space:]]//g' | grep -v '^$' | tr '\n' ' ')
  # shellcheck disable=SC2086
  if ! DEBIAN_FRONTEND=noninteractive $sudo apt-get -o DPkg::Lock::Timeout=600 install -y -qq \
         --no-install-recommends $deps >"$log" 2>&1; then
    absent rusticl "apt-get install of $pkg's libraries failed: $(grep -E '^(E|W):' "$log" | head -1)"
    rm -f "$log"; rm -rf "$tmp"; return 0
  fi
  rm -f "$log"
  dpkg-deb -x "$deb" "$tmp/root" || { absent rusticl "dpkg-deb -x $deb failed"; rm -rf "$tmp"; return 0; }
  mkdir -p "$tmp/$libdir"
  mv "$tmp/root/$libdir"/libRusticlOpenCL.so* "$tmp/$libdir/"
  dpkg-deb -f "$deb" Version > "$tmp/VERSION"
  rm -rf "$tmp/root" "$tmp/deb" "$dir"
  mv "$tmp" "$dir"
  rm -f deps/rusticl.absent
}

install_intel() {
  local dir=deps/intel-ocl
  if [ -f "$dir/VERSION" ] && [ "$(cat "$dir/VERSION")" = "$INTEL_VERSION tbb $TBB_VERSION" ] &&
     [ -f "$dir/lib/libintelocl.so" ]; then
    rm -f deps/intel.absent; return 0
  fi
  local pip=""
  for p in pip3 pip; do command -v "$p" >/dev/null 2>&1 && { pip=$p; break; }; done
  [ -z "$pip" ] && python3 -m pip --version >/dev/null 2>&1 && pip="python3 -m pip"
  if [ -z "$pip" ]; then absent intel "pip is not available (Debian: apt-get install python3-pip)"; return 0; fi
  if ! command -v unzip >/dev/null 2>&1 && ! command -v python3 >/dev/null 2>&1; then
    absent intel "neither unzip nor python3 is available to unpack the wheels"; return 0
  fi
  echo "install_opencl: fetching Intel's OpenCL runtime $INTEL_VERSION from PyPI (about 270 MB)" >&2
  rm -rf "$dir" "$dir.tmp"
  local tmp=$dir.tmp log
  mkdir -p "$tmp/wheels" "$tmp/lib" "$tmp/tbb"
  log=$(mktemp)
  if ! $pip download --no-deps --disable-pip-version-check -q -d "$tmp/wheels" \
         "intel-opencl-rt==$INTEL_VERSION" "intel-cmplr-lib-rt==$INTEL_VERSION" \
         "tbb==$TBB_VERSION" >"$log" 2>&1; then
    absent intel "pip download failed: $(grep -iE 'error' "$log" | head -1)"
    rm -f "$log"; rm -rf "$tmp"; return 0
  fi
  rm -f "$log"
  # Only what libintelocl.so loads: the ICD library, its compiler and built-in
  # libraries, and the Intel compiler runtime it links (found through its RUNPATH
  # $ORIGIN). Not the wheel's own libOpenCL.so: Debian's ICD loader stays.
  python3 - "$tmp" "$INTEL_VERSION" "$TBB_VERSION" <<'EOF' || { absent intel "unpacking the wheels failed"; rm -rf "$tmp"; return 0; }
import fnmatch, glob, os, shutil, sys, zipfile
tmp, ver, tbb = sys.argv[1:4]
want = {
    "intel_opencl_rt": ["libintelocl.so", "libcommon_clang.so.*", "cl.cfg", "*.rtl",
                        "cllibrary*.o", "libocl_svml_*.so"],
    "intel_cmplr_lib_rt": ["libimf.so", "libintlc.so.5", "libirng.so", "libsvml.so", "libirc.so"],
    "tbb": ["libtbb.so.12", "libtbbmalloc.so.2"],
}
for whl in glob.glob(os.path.join(tmp, "wheels", "*.whl")):
    pkg = os.path.basename(whl).split("-")[0]
    dest = os.path.join(tmp, "tbb" if pkg == "tbb" else "lib")
    with zipfile.ZipFile(whl) as z:
        for info in z.infolist():
            base = os.path.basename(info.filename)
            if "/data/lib/" in info.filename and any(fnmatch.fnmatch(base, p) for p in want.get(pkg, [])):
                with z.open(info) as src, open(os.path.join(dest, base), "wb") as out:
                    shutil.copyfileobj(src, out)
for need in ["lib/libintelocl.so", "lib/libimf.so", "tbb/libtbb.so.12"]:
    if not os.path.exists(os.path.join(tmp, need)):
        sys.exit("missing " + need)
EOF
  rm -rf "$tmp/wheels"
  echo "$INTEL_VERSION tbb $TBB_VERSION" > "$tmp/VERSION"
  mv "$tmp" "$dir"
  rm -f deps/intel.absent
}

targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(rusticl intel oclgrind)
for t in "${targets[@]}"; do
  case "$t" in
    rusticl) install_rusticl ;;
    oclgrind) apt_install oclgrind oclgrind ;;
    intel) install_intel ;;
    *) echo "error: install_opencl.sh: unknown implementation '$t' (known: rusticl, intel, oclgrind)" >&2; exit 2 ;;
  esac
done
exit 0
