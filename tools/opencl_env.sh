#!/usr/bin/env bash
# Prints the environment that shows a program exactly the named OpenCL
# implementations, without touching /etc: an ICD folder of our own in
# OCL_ICD_VENDORS (Debian's ICD loader, ocl-icd, reads only that folder when it is
# set), plus what each implementation needs. Names: pocl, rusticl, intel (see
# tools/install_opencl.sh), comma-separated for several.
#   eval "$(tools/opencl_env.sh intel)" && build/spectrace devices
# Exit status 1, with the reason on stderr, when one of them is not installed.
# Usage: tools/opencl_env.sh NAME[,NAME...] [ICD_DIR]   (default deps/icd/NAMES)
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
names=${1:?usage: tools/opencl_env.sh NAME[,NAME...] [ICD_DIR]}
dir=${2:-$root/deps/icd/${names//,/+}}

# The library of a Debian-installed ICD, by the name its .icd file gives.
# (ldconfig lives in /sbin, which a user's PATH may lack.)
system_lib() { # SONAME_PREFIX
  local ldc; ldc=$(command -v ldconfig || echo /sbin/ldconfig)
  "$ldc" -p 2>/dev/null | awk -v p="$1" '$1 ~ "^"p {print $NF; exit}'
}

envs=(); icds=()
IFS=, read -r -a list <<<"$names"
for n in "${list[@]}"; do
  case "$n" in
    pocl)
      lib=$(system_lib libpocl.so.2)
      [ -n "$lib" ] || { echo "pocl: not installed (Debian: apt-get install pocl-opencl-icd)" >&2; exit 1; }
      icds+=("pocl:$lib") ;;
    rusticl)
      # make deps unpacks Debian's mesa-opencl-icd into deps/rusticl; else a
      # system-wide install of it.
      lib=$root/deps/rusticl/usr/lib/x86_64-linux-gnu/libRusticlOpenCL.so.1
      [ -f "$lib" ] || lib=$(system_lib libRusticlOpenCL.so.1)
      if [ -z "$lib" ]; then
        why="not installed (make deps unpacks Debian's mesa-opencl-icd into deps/rusticl)"
        [ -f "$root/deps/rusticl.absent" ] && why=$(cat "$root/deps/rusticl.absent")
        echo "rusticl: $why" >&2; exit 1
      fi
      icds+=("rusticl:$lib")
      # rusticl offers no device unless a driver is enabled; swrast is llvmpipe.
      envs+=("RUSTICL_ENABLE=swrast") ;;
    intel)
      lib=$root/deps/intel-ocl/lib/libintelocl.so
      if [ ! -f "$lib" ]; then
        why="not installed (make deps fetches it from PyPI)"
        [ -f "$root/deps/intel.absent" ] && why=$(cat "$root/deps/intel.absent")
        echo "intel: $why" >&2; exit 1
      fi
      icds+=("intel:$lib")
      # libintelocl.so needs a newer oneTBB (libtbb.so.12) than Debian's, which
      # OpenImageIO loads first: the wheel's copy is found first (oneTBB keeps
      # backward compatibility for the older users).
      envs+=("LD_LIBRARY_PATH=$root/deps/intel-ocl/tbb\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}") ;;
    *) echo "error: opencl_env.sh: unknown implementation '$n' (known: pocl, rusticl, intel)" >&2; exit 2 ;;
  esac
done
mkdir -p "$dir" && rm -f "$dir"/*.icd
for entry in "${icds[@]}"; do
  echo "${entry#*:}" > "$dir/${entry%%:*}.icd"
done
echo "export OCL_ICD_VENDORS=$dir"
for v in "${envs[@]}"; do echo "export $v"; done
