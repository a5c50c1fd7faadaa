#!/bin/sh
# Output failures of the example programs (hetinv-reconstruct, hetinv-render,
# hetinv-fig4, hetinv-fig5, hetinv-medium-demo): every failed write is an
# error naming the file and the reason with a non-zero exit status, a bad
# output folder is refused before any simulation, an output folder is locked
# by the run that uses it, and temporaries a killed run left are removed.
#
#   io_failures.sh <case> <folder of the programs> <source tree> <work folder>
#
# Cases (one CTest test each): unwritable, not_folder, full_disk, stdout_full,
# text_outputs, lock, lock_link, stale_temporaries, stale_records, file_size_limit. Exit status 0 pass, 1 fail, 77 skip
# (a case the machine cannot stage: mounting a small file system, /dev/full).
# Tests run as root, for whom permission bits do not deny writes, so an
# unwritable folder is /proc (no files can be created there) or a read-only
# tmpfs mount.
set -u
case_name=$1
bin=$2
src=$3
work_root=$4
work=$work_root/$case_name
scene=$src/tests/data/reconstruct/tiny.json
render_scene=$src/examples/scenes/slab_reflectance.json
failures=0
mounted=""

rm -rf "$work"
mkdir -p "$work"

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

cleanup() {
  for m in $mounted; do umount "$m" 2>/dev/null; done
}
trap cleanup EXIT
trap 'cleanup; exit 1' HUP INT TERM

# run <name> <program> <args...>: runs a program, stdout to $work/<name>.out,
# stderr to $work/<name>.err, exit status to $rc.
run() {
  name=$1
  prog=$2
  shift 2
  "$bin/$prog" "$@" >"$work/$name.out" 2>"$work/$name.err"
  rc=$?
}

# expect_failure <name> <text the error must contain>: non-zero status, the
# text on stderr, and no "wrote" line for a run that failed.
expect_failure() {
  if [ "$rc" -eq 0 ]; then
    fail "$1: exit status 0, expected a failure ($(cat "$work/$1.err"))"
  fi
  if ! grep -qF -- "$2" "$work/$1.err"; then
    fail "$1: stderr lacks '$2':"
    sed 's/^/  | /' "$work/$1.err"
  fi
}

# expect_not_started <name> <text the program prints once it simulates>
expect_not_started() {
  if grep -qF -- "$2" "$work/$1.out" "$work/$1.err"; then
    fail "$1: the program got to '$2' before refusing its output folder"
  fi
}

# expect_no_temporaries <folder>
expect_no_temporaries() {
  left=$(find "$1" -name '*.hetinv-tmp-*' 2>/dev/null)
  if [ -n "$left" ]; then
    fail "temporary files left in $1: $left"
  fi
}

# mount_tmpfs <folder> <options>: 0 if mounted.
mount_tmpfs() {
  mkdir -p "$1"
  if mount -t tmpfs -o "$2" hetinv-io-test "$1" 2>/dev/null; then
    mounted="$1 $mounted"
    return 0
  fi
  return 1
}

unmount() {
  umount "$1"
  mounted=$(echo "$mounted" | sed "s| *$1 *| |")
}

# Mounting needs root; without it, try again inside a user and mount
# namespace (unprivileged user namespaces), else the case is skipped.
need_mount() {
  if mount_tmpfs "$work/probe" size=4k; then
    unmount "$work/probe"
    return 0
  fi
  if [ -z "${HETINV_IO_UNSHARED:-}" ] && command -v unshare >/dev/null 2>&1 &&
     unshare --user --map-root-user --mount true 2>/dev/null; then
    HETINV_IO_UNSHARED=1 exec unshare --user --map-root-user --mount sh "$0" "$case_name" "$bin" "$src" "$work_root"
  fi
  echo "SKIP: $case_name: cannot mount a small tmpfs here (not root, no user namespaces)"
  exit 77
}

reconstruct_files="measurements.exr checkpoint.bin loss.csv errors.csv maps.exr maps_sigma_a.png
  maps_sigma_s.png maps_g.png recovered_sigma_a.vol recovered_sigma_s.vol recovered_g.vol
  truth_sigma_a.vol truth_sigma_s.vol truth_g.vol bound.exr bound_sigma_a.png bound_sigma_s.png
  bound_g.png"

case $case_name in

unwritable)
  # An existing folder nobody can create files in, and a folder that cannot
  # be created: refused before the simulation, the reason given.
  for dir in /proc /proc/hetinv-no-such/out; do
    run r hetinv-reconstruct "$scene" --threads 1 -o "$dir" --quiet
    expect_failure r "hetinv-reconstruct: ${dir%/out}"
    expect_not_started r "voxels"
    run d hetinv-render "$render_scene" --photons 100 --threads 1 -o "$dir"
    expect_failure d "hetinv-render: ${dir%/out}"
    expect_not_started d "photons per emitter"
    run f5 hetinv-fig5 --grid 2 --iterations 1 --photons 10 --threads 1 --quiet -o "$dir"
    expect_failure f5 "hetinv-fig5: ${dir%/out}"
    expect_not_started f5 "voxels"
    run f4 hetinv-fig4 --grid 2 --volumes 1 --iterations 1 --photons 10 --configs 1 -o "$dir"
    expect_failure f4 "hetinv-fig4: ${dir%/out}"
    expect_not_started f4 "sources"
    run m hetinv-medium-demo "$dir"
    expect_failure m "hetinv-medium-demo: ${dir%/out}"
    expect_not_started m "wrote"
  done
  # A read-only file system, where the machine lets us mount one.
  if mount_tmpfs "$work/ro" ro,size=64k; then
    run ro hetinv-reconstruct "$scene" --threads 1 -o "$work/ro" --quiet
    expect_failure ro "Read-only file system"
    expect_not_started ro "voxels"
    run rod hetinv-render "$render_scene" --photons 100 --threads 1 -o "$work/ro"
    expect_failure rod "Read-only file system"
    expect_not_started rod "photons per emitter"
  else
    echo "note: no read-only tmpfs (cannot mount here); /proc covered the case"
  fi
  ;;

not_folder)
  # -o names a regular file, or a path through one: refused at once.
  : >"$work/file"
  for dir in "$work/file" "$work/file/sub"; do
    run r hetinv-reconstruct "$scene" --threads 1 -o "$dir" --quiet
    expect_failure r "Not a directory"
    expect_not_started r "voxels"
    run d hetinv-render "$render_scene" --photons 100 --threads 1 -o "$dir"
    expect_failure d "Not a directory"
    expect_not_started d "photons per emitter"
    run f5 hetinv-fig5 --grid 2 --iterations 1 --photons 10 --threads 1 --quiet -o "$dir"
    expect_failure f5 "Not a directory"
    expect_not_started f5 "voxels"
    run f4 hetinv-fig4 --grid 2 --volumes 1 --iterations 1 --photons 10 --configs 1 -o "$dir"
    expect_failure f4 "Not a directory"
    expect_not_started f4 "sources"
    run m hetinv-medium-demo "$dir"
    expect_failure m "Not a directory"
  done
  ;;

full_disk)
  # A tmpfs of 4 KiB to 128 KiB: each size fills up at a different output
  # file. Every run either succeeds with all its files, or fails naming the
  # reason without claiming it wrote them; none leaves a temporary behind.
  need_mount
  fs=$work/fs
  sizes_failed=0
  sizes_passed=0
  for k in 4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64 80 96 112 128; do
    mount_tmpfs "$fs" size=${k}k || { fail "cannot mount a ${k}k tmpfs"; break; }
    run r$k hetinv-reconstruct "$scene" --threads 1 -o "$fs/out" --quiet
    if [ "$rc" -eq 0 ]; then
      sizes_passed=$((sizes_passed + 1))
      for f in $reconstruct_files; do
        [ -s "$fs/out/$f" ] || fail "${k}k: exit status 0 but $f is missing or empty"
      done
      grep -q "^wrote " "$work/r$k.out" || fail "${k}k: exit status 0 without 'wrote'"
    else
      sizes_failed=$((sizes_failed + 1))
      expect_failure r$k "No space left on device"
      if grep -q "^wrote " "$work/r$k.out"; then fail "${k}k: 'wrote' printed by a failed run"; fi
    fi
    expect_no_temporaries "$fs/out"
    # hetinv-render's images (four files of one row), at every other size.
    if [ $((k % 8)) -ne 4 ]; then
      unmount "$fs"
      continue
    fi
    run d$k hetinv-render "$render_scene" --photons 100 --threads 1 -o "$fs/render"
    if [ "$rc" -ne 0 ]; then
      expect_failure d$k "No space left on device"
    elif [ ! -s "$fs/render/below_beam.png" ]; then
      fail "${k}k: hetinv-render exit status 0 without below_beam.png"
    fi
    expect_no_temporaries "$fs/render"
    unmount "$fs"
  done
  # A checkpoint larger than the stdio buffer: its fwrite itself fails.
  # 12k as before the run record, plus the record's own 4 KiB page, the
  # 4 KiB reserved for its end, and a page of slack.
  mount_tmpfs "$fs" size=24k || fail "cannot mount a 24k tmpfs"
  run big hetinv-reconstruct "$src/tests/data/reconstruct/io_checkpoint.json" --threads 1 -o "$fs/big" --quiet \
    --no-bound
  expect_failure big "checkpoint.bin': No space left on device"
  expect_no_temporaries "$fs/big"
  unmount "$fs"
  echo "hetinv-reconstruct: $sizes_failed sizes failed (disk full), $sizes_passed succeeded"
  [ "$sizes_failed" -gt 0 ] || fail "no size was small enough to fill up"
  [ "$sizes_passed" -gt 0 ] || fail "no size was large enough to succeed"
  ;;

stdout_full)
  # Standard output on a full device: printf fails quietly unless checked.
  if [ ! -w /dev/full ]; then
    echo "SKIP: stdout_full: no /dev/full"
    exit 77
  fi
  "$bin/hetinv-reconstruct" "$scene" --threads 1 -o "$work/r" --quiet >/dev/full 2>"$work/r.err"
  rc=$?
  expect_failure r "hetinv-reconstruct: standard output: No space left on device"
  "$bin/hetinv-render" "$render_scene" --photons 100 --threads 1 --totals-json --quiet -o "$work/d" >/dev/full 2>"$work/d.err"
  rc=$?
  expect_failure d "hetinv-render: standard output: No space left on device"
  "$bin/hetinv-medium-demo" "$work/m" >/dev/full 2>"$work/m.err"
  rc=$?
  expect_failure m "hetinv-medium-demo: standard output: No space left on device"
  ;;

text_outputs)
  # The programs' own text files (CSV tables): a directory in the place of
  # the file makes its final rename fail, as root too.
  for f in loss.csv errors.csv; do
    mkdir -p "$work/$f/$f"
    run $f hetinv-reconstruct "$scene" --threads 1 -o "$work/$f" --quiet
    expect_failure $f "hetinv-reconstruct: $work/$f/$f: Is a directory"
    if grep -q "^wrote " "$work/$f.out"; then fail "$f: 'wrote' printed by a failed run"; fi
    expect_no_temporaries "$work/$f"
  done
  mkdir -p "$work/fig4/fig4_table.csv"
  run f4 hetinv-fig4 --grid 2 --volumes 1 --iterations 1 --photons 10 --configs 1 --threads 1 --quiet -o "$work/fig4"
  expect_failure f4 "hetinv-fig4: $work/fig4/fig4_table.csv: Is a directory"
  if grep -q "table in" "$work/f4.out"; then fail "fig4: 'table in' printed by a failed run"; fi
  expect_no_temporaries "$work/fig4"
  ;;

lock)
  # Two runs on one folder: the first holds the lock (kept stopped while
  # the second tries); the second stops at once naming the folder and the
  # holder, and leaves the first one's files alone; the first then
  # finishes. A --resume run afterwards takes the lock again. Should the
  # first run end before it could be stopped (a loaded machine), the case
  # is tried again with a longer first run.
  dir=$work/out
  iterations=60
  for attempt in 1 2 3; do
    rm -rf "$dir"
    "$bin/hetinv-reconstruct" "$scene" --threads 1 -o "$dir" --quiet --iterations $iterations \
      >"$work/a.out" 2>"$work/a.err" &
    a=$!
    i=0
    holder=""
    while [ "$holder" != "$a" ] && [ $i -lt 1000 ]; do
      sleep 0.01
      holder=""
      { read -r holder <"$dir/.hetinv.lock"; } 2>/dev/null
      i=$((i + 1))
    done
    kill -STOP $a 2>/dev/null
    # SIGSTOP arrives asynchronously: wait until the run is stopped (T) or over.
    j=0
    while [ $j -lt 500 ]; do
      state=$(cut -d' ' -f3 "/proc/$a/stat" 2>/dev/null)
      case $state in T | t | Z | X | "") break ;; esac
      sleep 0.01
      j=$((j + 1))
    done
    if [ "$holder" != "$a" ]; then
      fail "the first run never recorded itself in $dir/.hetinv.lock"
      break
    fi
    [ "$state" = "T" ] && break
    echo "note: attempt $attempt: the first run ended before it could be stopped; trying a longer one"
    kill -CONT $a 2>/dev/null
    wait $a
    iterations=$((iterations * 4))
  done
  : >"$dir/planted.hetinv-tmp-Ab12Cd"
  run b hetinv-reconstruct "$scene" --threads 1 -o "$dir" --quiet
  expect_failure b "hetinv-reconstruct: $dir: the output folder is in use by another run (process $a)"
  expect_not_started b "voxels"
  [ -e "$dir/planted.hetinv-tmp-Ab12Cd" ] || fail "the refused run removed a temporary of the running one"
  run rd hetinv-render "$render_scene" --photons 100 --threads 1 -o "$dir"
  expect_failure rd "hetinv-render: $dir: the output folder is in use by another run"
  kill -CONT $a 2>/dev/null
  wait $a
  rc=$?
  [ "$rc" -eq 0 ] || fail "the first run failed ($rc): $(cat "$work/a.err")"
  [ -s "$dir/errors.csv" ] || fail "the first run did not write errors.csv"
  run c hetinv-reconstruct "$scene" --threads 1 -o "$dir" --quiet --iterations $iterations --resume
  [ "$rc" -eq 0 ] || fail "a --resume run after the first failed: $(cat "$work/c.err")"
  ;;

lock_link)
  # A lock file that links elsewhere (planted in a shared folder, say) is
  # refused before any simulation, and the file it names keeps its bytes:
  # the run would otherwise write its process id over it.
  echo "precious" >"$work/target"
  for kind in symbolic hard; do
    dir=$work/$kind
    mkdir -p "$dir"
    if [ $kind = symbolic ]; then ln -s "$work/target" "$dir/.hetinv.lock"; else ln "$work/target" "$dir/.hetinv.lock"; fi
    run $kind hetinv-render "$render_scene" --photons 100 --threads 1 -o "$dir"
    expect_failure $kind "hetinv-render: $dir/.hetinv.lock: the lock file is a"
    expect_not_started $kind "R_"
    [ "$(cat "$work/target")" = "precious" ] || fail "$kind: the file the lock file links to was overwritten"
  done
  ;;

stale_temporaries)
  # Files of the writers' temporary pattern, left by a killed run, are gone
  # after the next run; other names are kept, another program's temporaries
  # (mkstemp's ".tmp-XXXXXX" without the library's tag) among them.
  for p in reconstruct render demo; do
    dir=$work/$p
    mkdir -p "$dir/kept.hetinv-tmp-ABCDEF"
    : >"$dir/checkpoint.bin.hetinv-tmp-Ab12Cd"
    : >"$dir/maps.exr.hetinv-tmp-zz9ZZ9"
    : >"$dir/notes.hetinv-tmp-12345"
    : >"$dir/thesis.tex.tmp-Ab12Cd"
    : >"$dir/notes.txt"
    case $p in
      reconstruct) run $p hetinv-reconstruct "$scene" --threads 1 -o "$dir" --quiet ;;
      render) run $p hetinv-render "$render_scene" --photons 100 --threads 1 -o "$dir" ;;
      demo) run $p hetinv-medium-demo "$dir" ;;
    esac
    [ "$rc" -eq 0 ] || fail "$p: exit status $rc: $(cat "$work/$p.err")"
    for f in checkpoint.bin.hetinv-tmp-Ab12Cd maps.exr.hetinv-tmp-zz9ZZ9; do
      [ ! -e "$dir/$f" ] || fail "$p: the stale temporary $f is still there"
    done
    for f in kept.hetinv-tmp-ABCDEF notes.hetinv-tmp-12345 thesis.tex.tmp-Ab12Cd notes.txt; do
      [ -e "$dir/$f" ] || fail "$p: $f was removed (not a temporary of the writers)"
    done
  done
  ;;

stale_records)
  # hetinv-fig4 reads a finished cell back from its cell.csv (bound.csv for
  # its bound). A run under other settings that stops after replacing some
  # of the cell's files (killed, or a failed write: here a folder in the
  # place of maps.exr, bound_g.png) must not leave the old record beside
  # them: a rerun under the old settings would report the old figures as
  # that cell's while its folder holds the other run's recovery.
  dir=$work/fig4
  cell=$dir/config1_volume1
  f4="--grid 2 --volumes 1 --photons 20 --configs 1 --threads 1 --quiet -o $dir"
  run x hetinv-fig4 $f4 --iterations 40
  [ "$rc" -eq 0 ] || fail "first run: exit status $rc: $(cat "$work/x.err")"
  cp "$cell/recovered_sigma_a.vol" "$work/x_recovered_sigma_a.vol"
  rm -f "$cell/maps.exr"
  mkdir -p "$cell/maps.exr/in-the-way"
  run y hetinv-fig4 $f4 --iterations 41
  expect_failure y "maps.exr"
  # Its checkpoint too, which a rerun under the old settings would refuse.
  rm -r "$cell/maps.exr" "$cell/checkpoint.bin"
  run x2 hetinv-fig4 $f4 --iterations 40
  [ "$rc" -eq 0 ] || fail "rerun: exit status $rc: $(cat "$work/x2.err")"
  [ -s "$cell/maps.exr" ] || fail "the rerun reused the cell without its maps.exr"
  cmp -s "$work/x_recovered_sigma_a.vol" "$cell/recovered_sigma_a.vol" ||
    fail "the rerun reused cell.csv beside recovered_sigma_a.vol of the run under other settings"
  # The bound: bound.exr replaced, bound_g.png in the way.
  run bx hetinv-fig4 $f4 --iterations 40 --bound-only --bound-photons 30 --bound-replicates 2
  [ "$rc" -eq 0 ] || fail "bound: exit status $rc: $(cat "$work/bx.err")"
  cp "$cell/bound.exr" "$work/bx_bound.exr"
  rm -f "$cell/bound_g.png"
  mkdir -p "$cell/bound_g.png/in-the-way"
  run by hetinv-fig4 $f4 --iterations 40 --bound-only --bound-photons 31 --bound-replicates 2
  expect_failure by "bound_g.png"
  rm -r "$cell/bound_g.png"
  run bx2 hetinv-fig4 $f4 --iterations 40 --bound-only --bound-photons 30 --bound-replicates 2
  [ "$rc" -eq 0 ] || fail "bound rerun: exit status $rc: $(cat "$work/bx2.err")"
  [ -s "$cell/bound_g.png" ] || fail "the rerun reused the bound without its bound_g.png"
  cmp -s "$work/bx_bound.exr" "$cell/bound.exr" ||
    fail "the rerun reused bound.csv beside bound.exr of the run under other settings"
  expect_no_temporaries "$dir"
  ;;

file_size_limit)
  # A file size limit (ulimit -f; SIGXFSZ ignored, so writes fail with
  # EFBIG) met while hetinv-fig4 --bound-from copies a bound's maps: the
  # error names the copy and the reason, not a generic I/O error. The
  # source's bound.exr is replaced by 64 KiB of other bytes (the copy does
  # not read them), larger than stdio's buffer, so fwrite itself fails.
  b4="--grid 2 --volumes 1 --iterations 2 --photons 20 --configs 2 --threads 1 --quiet --bound-only
    --bound-photons 30 --bound-replicates 2"
  run from hetinv-fig4 $b4 -o "$work/from"
  [ "$rc" -eq 0 ] || fail "the bound to copy: exit status $rc: $(cat "$work/from.err")"
  head -c 65536 /dev/zero >"$work/from/config2_volume1/bound.exr"
  sh -c 'trap "" XFSZ; ulimit -f 16; exec "$@"' sh "$bin/hetinv-fig4" $b4 --bound-from "$work/from" -o "$work/to" \
    >"$work/to.out" 2>"$work/to.err"
  rc=$?
  expect_failure to "hetinv-fig4: $work/to/config2_volume1/bound.exr: File too large"
  expect_no_temporaries "$work/to"
  [ ! -e "$work/to/config2_volume1/bound.csv" ] || fail "bound.csv written though its maps were not copied"
  ;;

*)
  echo "unknown case '$case_name'"
  exit 2
  ;;
esac

if [ "$failures" -gt 0 ]; then
  echo "$case_name: $failures failure(s)"
  exit 1
fi
echo "$case_name: passed"
exit 0
