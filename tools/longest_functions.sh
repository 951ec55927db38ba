#!/usr/bin/env bash
# Lists the longest functions and methods of lib/ and cli/ (default: ten), longest first, as
# "lines  file:line  name", from universal-ctags' start and end lines of each definition.
# The house rule is about 150 lines per function; tools/check.sh prints this list.
# Usage: tools/longest_functions.sh [COUNT]
set -euo pipefail
count=${1:-10}
cd "$(dirname "$0")/.."
if ! command -v ctags >/dev/null 2>&1 || ! ctags --version 2>/dev/null | grep -q "Universal Ctags"; then
  echo "longest_functions: universal-ctags is missing (tools/setup.sh installs it)" >&2
  exit 1
fi
ctags -R --languages=C++ --kinds-C++=f --fields=+ne --extras=-F -f - lib cli |
  awk -F'\t' '{
    start = ""; end = ""; scope = "";
    for (i = 4; i <= NF; i++) {
      if ($i ~ /^line:/) start = substr($i, 6);
      else if ($i ~ /^end:/) end = substr($i, 5);
      else if ($i ~ /^(class|struct|namespace):/) scope = substr($i, index($i, ":") + 1) "::";
    }
    if (start == "" || end == "") next;
    gsub(/__anon[0-9a-f]+::/, "", scope);
    printf "%d\t%s:%s\t%s%s\n", end - start + 1, $2, start, scope, $1;
  }' |
  sort -t$'\t' -k1,1nr -k2,2 |
  awk -F'\t' -v n="$count" 'BEGIN { printf "%6s  %-40s %s\n", "lines", "where", "function" }
    NR <= n { printf "%6d  %-40s %s\n", $1, $2, $3 }'
