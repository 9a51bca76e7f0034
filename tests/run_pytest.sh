#!/usr/bin/env bash
# Runs the Python module's tests (src/python/tests, pytest) against
# BUILD/libspectrace.so on PoCL, from the source tree, with the first Python
# that has NumPy and pytest: BUILD/venv's (make python), python3, or Debian's
# (tools/install_deps.sh installs python3-numpy and python3-pytest). Without
# one it says so and skips. Usage: tests/run_pytest.sh BUILD_DIR
set -u
build=${1:?usage: tests/run_pytest.sh BUILD_DIR}
cd "$(dirname "$0")/.."
export SPECTRACE_LIB=$PWD/$build/libspectrace.so
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
eval "$(tools/opencl_env.sh pocl)" || exit 1
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
PYTHONPATH=$PWD/src/python exec "$py" -m pytest -q -p no:cacheprovider src/python/tests
