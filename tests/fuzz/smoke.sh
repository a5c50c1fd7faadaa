#!/bin/sh
# Runs a libFuzzer harness for a bounded time on a copy of its seed corpus
# (so the checked-in corpus is never modified). Exit status: the fuzzer's;
# on a crash the reproducer is kept and its path printed.
# Usage: smoke.sh <fuzzer> <seed-corpus-dir> [<dictionary>] [<seconds>]
set -eu
fuzzer=$1
seeds=$2
dict=${3:-}
seconds=${4:-30}

work=$(mktemp -d "${TMPDIR:-/tmp}/hetinv-fuzz-XXXXXX")
mkdir "$work/corpus" "$work/artifacts"
cp "$seeds"/* "$work/corpus/"

set -- -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
       -artifact_prefix="$work/artifacts/"
if [ -n "$dict" ]; then set -- "$@" -dict="$dict"; fi

status=0
"$fuzzer" "$@" "$work/corpus" || status=$?
if [ "$status" -eq 0 ]; then
  rm -rf "$work"
else
  echo "smoke.sh: $fuzzer failed (status $status); reproducer(s) kept in $work/artifacts:" >&2
  ls -l "$work/artifacts" >&2
fi
exit "$status"
