#!/bin/sh
# Every symbol the shared library defines for the dynamic linker must be a
# hetinv_* function or object; anything else leaks an internal name.
set -eu
lib=$1
symbols=$(nm -D --defined-only "$lib" | awk '{print $3}' | sed 's/@.*//' | sort -u)
count=$(printf '%s\n' "$symbols" | grep -c '^hetinv_' || true)
stray=$(printf '%s\n' "$symbols" | grep -v '^hetinv_' | grep -v '^$' || true)
if [ -n "$stray" ]; then
  echo "symbols exported without the hetinv_ prefix:"
  printf '%s\n' "$stray"
  exit 1
fi
if [ "$count" -eq 0 ]; then
  echo "no hetinv_ symbols exported at all from $lib"
  exit 1
fi
echo "exported symbols: $count, all hetinv_*"
