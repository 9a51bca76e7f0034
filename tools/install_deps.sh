#!/usr/bin/env bash
# Installs the Debian packages spectrace needs, and only those that are missing.
# Idempotent: a second run checks, finds everything present and installs nothing.
# Where apt-get is not available it stops and names the packages to install.
set -eu

packages=(
  build-essential pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers clinfo
  libtinygltf-dev libstb-dev nlohmann-json3-dev
  libopenimageio-dev libopenexr-dev
  libcmocka-dev
  libdraco-dev libmeshoptimizer-dev
  python3-numpy python3-pytest python3-venv
)
# Extra groups, asked for by name: "mpi" for build/spectrace-mpi, "pip" for
# tools/install_oidn.sh.
for group in "$@"; do
  case "$group" in
    mpi) packages+=(openmpi-bin libopenmpi-dev) ;;
    pip) packages+=(python3-pip) ;;
    *) echo "error: install_deps.sh: unknown package group '$group' (known: mpi, pip)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [ "$status" = "install ok installed" ] || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if ! command -v apt-get >/dev/null 2>&1; then
  echo "error: apt-get is not available; install these packages (Debian 12 names) and run again: ${missing[*]}" >&2
  exit 3
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
    echo "error: not root and no sudo; as root run: apt-get install ${missing[*]}" >&2
    exit 3
  fi
fi
echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
