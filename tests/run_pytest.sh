#!/usr/bin/env bash
# Runs the Python module's tests (src/python/tests, pytest) against
# BUILD/libspectrace.so from the source tree, on one OpenCL implementation
# (IMPL: pocl, the default; pocl-gpu, PoCL with the kernels' GPU code path;
# intel; rusticl: the names of tests/run_tests.sh, made the only one the tests
# see by tools/opencl_env.sh), with the first Python that has NumPy and pytest:
# BUILD/venv's (make python), python3, or Debian's (tools/install_deps.sh
# installs python3-numpy and python3-pytest). Without one it says so and skips;
# an implementation that is not installed fails.
# Usage: tests/run_pytest.sh BUILD_DIR [IMPL] [PYTEST_ARGS...]
set -u
build=${1:?usage: tests/run_pytest.sh BUILD_DIR [IMPL] [PYTEST_ARGS...]}
impl=${2:-pocl}
shift $(( $# < 2 ? $# : 2 ))
cd "$(dirname "$0")/.."
export SPECTRACE_LIB=$PWD/$build/libspectrace.so
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
base=$impl
case "$impl" in
  pocl|intel|rusticl) ;;
  pocl-gpu) base=pocl; export SPECTRACE_KERNEL_PATH=gpu ;;
  *) echo "run_pytest.sh: IMPL is pocl, pocl-gpu, intel or rusticl, not '$impl'" >&2; exit 2 ;;
esac
envs=$(tools/opencl_env.sh "$base" "$PWD/$build/icd/$base") || exit 1
eval "$envs"
py=""
for c in "$build/venv/bin/python" python3 /usr/bin/python3; do
  if command -v "$c" >/dev/null 2>&1 && "$c" -c 'import numpy, pytest' 2>/dev/null; then
    py=$c
    break
  fi
done
if [ -z "$py" ]; then
  echo "python tests: skipped: no Python with numpy and pytest (tools/install_deps.sh or make python)"
  exit 0
fi
echo "== python tests ($impl)"
PYTHONPATH=$PWD/src/python exec "$py" -m pytest -q -p no:cacheprovider src/python/tests "$@"
