#!/usr/bin/env bash
# Checks the host's layering: a file under src/ may include (#include "DIR/...")
# only from its own folder or from a folder after it in the pipeline order of
# docs/architecture.md ("Source layout"), read from its line
#   pipeline: cli -> mpi -> render -> scene -> color -> io/cl/accel -> core
# (steps left to right; folders on one step, separated by "/", may not include
# each other). Includes rooted elsewhere (kernels/: util/, closure/, ...) are
# not the host's folders and are not checked; an include through ".." is
# refused, as is a folder of src/ that the line does not name.
# Usage: tools/check_includes.sh [ROOT]   (ROOT: the source tree, by default
# the one holding this script). Prints one line per offending include, naming
# the file, the line and the include. Exit status: 0 when none, 1 when some,
# 2 when the pipeline line is missing.
set -u
root=${1:-$(cd "$(dirname "$0")/.." && pwd)}
doc=$root/docs/architecture.md
line=$(grep -m1 '^pipeline: ' "$doc" 2>/dev/null)
if [ -z "$line" ]; then
  echo "check_includes.sh: no 'pipeline: ...' line in $doc" >&2
  exit 2
fi
order=${line#pipeline: }
cd "$root" || exit 2
find src -type f \( -name '*.c' -o -name '*.h' -o -name '*.cpp' -o -name '*.hpp' \) | sort |
  xargs grep -nE '^[[:space:]]*#[[:space:]]*include[[:space:]]*"' /dev/null |
  awk -v order="$order" -v folders="$(find src -mindepth 1 -maxdepth 1 -type d -printf '%f\n' | sort)" '
    BEGIN {
      n = split(order, steps, /[[:space:]]*->[[:space:]]*/)
      for (i = 1; i <= n; i++) {
        m = split(steps[i], fs, "/")
        for (j = 1; j <= m; j++) { gsub(/[[:space:]]/, "", fs[j]); if (fs[j] != "") rank[fs[j]] = i }
      }
      bad = 0
      k = split(folders, fl, "\n")
      for (i = 1; i <= k; i++)
        if (fl[i] != "" && !(fl[i] in rank)) {
          printf "src/%s/: a folder that the pipeline line of docs/architecture.md does not name\n", fl[i]
          bad = 1
        }
    }
    {
      # FILE:LINE:#include "X"
      file = $0; sub(/:.*/, "", file)
      rest = substr($0, length(file) + 2); ln = rest; sub(/:.*/, "", ln)
      inc = rest; sub(/^[^"]*"/, "", inc); sub(/".*/, "", inc)
      split(file, parts, "/"); own = parts[2]
      if (!(own in rank)) next
      if (inc ~ /(^|\/)\.\.\//) {
        printf "%s:%s: includes \"%s\" through \"..\" (includes are rooted at src/ or kernels/)\n", file, ln, inc
        bad = 1; next
      }
      if (inc !~ /\//) next
      dir = inc; sub(/\/.*/, "", dir)
      if (!(dir in rank) || dir == own) next
      if (rank[dir] <= rank[own]) {
        printf "%s:%s: includes \"%s\": %s/ is not after %s/ in the pipeline order (docs/architecture.md: %s)\n", file, ln, inc, dir, own, order
        bad = 1
      }
    }
    END { exit bad }'
