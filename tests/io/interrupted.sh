#!/bin/sh
# Interrupted runs of the example programs: a run killed part-way and run
# again (hetinv-reconstruct --resume; hetinv-fig4 cell by cell) ends with
# the results of a run never interrupted, bit for bit, its run time aside.
#
#   interrupted.sh <case> <folder of the programs> <source tree> <work folder>
#
# Cases (one CTest test each): reconstruct_killed, fig4_killed,
# fig5_killed (--resume), stage_results_resumed, stop_hint (SIGTERM's line),
# run_record (the folder's hetinv-run.json; the killed cases check it too). Exit status
# 0 pass, 1 fail. The kill comes once a checkpoint exists (the run is then
# mid-way); on a machine fast enough to finish first, the rerun still has
# to give the same results.
set -u
case_name=$1
bin=$2
src=$3
work_root=$4
work=$work_root/$case_name
failures=0

rm -rf "$work"
mkdir -p "$work"

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

# kill_when <file> <pid>: SIGKILL to pid once file exists (or the process ended).
kill_when() {
  i=0
  while [ ! -e "$1" ] && kill -0 "$2" 2>/dev/null && [ $i -lt 3000 ]; do
    sleep 0.01
    i=$((i + 1))
  done
  kill -9 "$2" 2>/dev/null
  wait "$2" 2>/dev/null
}

# same <a> <b> <file...>: each file byte for byte equal in folders a and b.
same() {
  a=$1
  b=$2
  shift 2
  for f in "$@"; do
    if [ ! -e "$b/$f" ]; then
      fail "$b/$f is missing"
    elif ! cmp -s "$a/$f" "$b/$f"; then
      fail "$b/$f differs from the uninterrupted run's $a/$f"
    fi
  done
}

# record_says <folder> <status>: its run record's status.
record_says() {
  if ! grep -q "\"status\":[[:space:]]*\"$2\"" "$1/hetinv-run.json" 2>/dev/null; then
    fail "$1/hetinv-run.json does not say \"$2\":"
    sed 's/^/  | /' "$1/hetinv-run.json" 2>&1 | head -20
  fi
}

# record_lists <folder> <list> <name...>: names in the record's list
# ("files" entries or "older_files"), checked by the line each sits on.
record_lists() {
  folder=$1
  list=$2
  shift 2
  for f in "$@"; do
    if [ "$list" = files ]; then
      grep -q "\"name\":[[:space:]]*\"$f\"" "$folder/hetinv-run.json" || fail "the run record does not list $f as written"
    else
      sed -n '/"older_files"/,$p' "$folder/hetinv-run.json" | grep -q "\"$f\"" ||
        fail "the run record does not list $f as an older file"
    fi
  done
}

# The table without its last column (seconds, a run time).
figures() {
  sed 's/,[^,]*$//' "$1"
}

case $case_name in

reconstruct_killed)
  scene=$src/tests/data/reconstruct/tiny.json
  args="$scene --threads 1 --iterations 80 --quiet"
  "$bin/hetinv-reconstruct" $args -o "$work/ref" >"$work/ref.out" 2>&1 || fail "the uninterrupted run failed"
  "$bin/hetinv-reconstruct" $args -o "$work/run" >"$work/a.out" 2>&1 &
  kill_when "$work/run/checkpoint.bin" $!
  [ -e "$work/run/recovered_g.vol" ] || record_says "$work/run" running # killed before its end
  "$bin/hetinv-reconstruct" $args -o "$work/run" --resume >"$work/b.out" 2>&1 || fail "the --resume run failed"
  same "$work/ref" "$work/run" recovered_sigma_a.vol recovered_sigma_s.vol recovered_g.vol loss.csv errors.csv \
    maps.exr measurements.exr bound.exr
  # The resumed run's record keeps the first part's start, so the
  # measurements that part wrote are the run's own.
  record_says "$work/run" complete
  record_lists "$work/run" files measurements.exr checkpoint.bin recovered_g.vol errors.csv
  grep -q '"resumes":[[:space:]]*1' "$work/run/hetinv-run.json" || fail "the run record does not count one resume"
  ;;

fig4_killed)
  # Two volumes: a rerun reads the first cell back from its cell.csv and
  # resumes the second from its checkpoint; the table of stored figures
  # must be the one the uninterrupted run printed.
  args="--grid 2 --volumes 2 --iterations 60 --photons 20 --truth-photons 2000 --configs 2 --threads 1 --quiet"
  "$bin/hetinv-fig4" $args -o "$work/ref" >"$work/ref.out" 2>&1 || fail "the uninterrupted run failed"
  "$bin/hetinv-fig4" $args -o "$work/run" >"$work/a.out" 2>&1 &
  kill_when "$work/run/config2_volume2/checkpoint.bin" $!
  [ -e "$work/run/fig4_table.csv" ] || record_says "$work/run" running
  "$bin/hetinv-fig4" $args -o "$work/run" >"$work/b.out" 2>&1 || fail "the rerun failed"
  record_says "$work/run" complete
  record_lists "$work/run" files config2_volume1/errors.csv config2_volume2/errors.csv fig4_table.csv
  for v in 1 2; do
    same "$work/ref/config2_volume$v" "$work/run/config2_volume$v" recovered_sigma_a.vol recovered_sigma_s.vol \
      recovered_g.vol loss.csv errors.csv maps.exr
  done
  figures "$work/ref/fig4_table.csv" >"$work/ref_table"
  figures "$work/run/fig4_table.csv" >"$work/run_table"
  if ! cmp -s "$work/ref_table" "$work/run_table"; then
    fail "the rerun's fig4_table.csv differs from the uninterrupted run's:"
    diff "$work/ref_table" "$work/run_table" | sed 's/^/  | /'
  fi
  # A third run reads every cell back: the same table again.
  "$bin/hetinv-fig4" $args -o "$work/run" >"$work/c.out" 2>&1 || fail "the third run failed"
  figures "$work/run/fig4_table.csv" >"$work/run_table"
  cmp -s "$work/ref_table" "$work/run_table" || fail "a table of stored cells differs from the uninterrupted run's"
  ;;

stop_hint)
  # SIGTERM (a batch system's stop; SIGINT, Ctrl-C, alike, but a background
  # job of this shell ignores it): the run ends by the signal, after a line
  # saying how to continue.
  scene=$src/tests/data/reconstruct/tiny.json
  args="$scene --threads 1 --iterations 300 --quiet --no-bound"
  "$bin/hetinv-reconstruct" $args -o "$work/run" >"$work/a.out" 2>"$work/a.err" &
  pid=$!
  i=0
  while [ ! -e "$work/run/checkpoint.bin" ] && kill -0 $pid 2>/dev/null && [ $i -lt 3000 ]; do
    sleep 0.01
    i=$((i + 1))
  done
  kill -TERM $pid
  wait $pid
  rc=$?
  [ $rc -eq 143 ] || fail "exit status $rc after SIGTERM, not 143 (ended by the signal)"
  grep -q "^hetinv-reconstruct: stopped; the same command with --resume continues from the last checkpoint, \
$work/run/checkpoint.bin" "$work/a.err" || { fail "no hint on stderr:"; sed 's/^/  | /' "$work/a.err"; }
  "$bin/hetinv-reconstruct" $args -o "$work/run" --resume >"$work/b.out" 2>&1 || fail "the --resume run failed"
  ;;

fig5_killed)
  args="--grid 2 --iterations 100 --photons 20 --threads 1 --quiet"
  "$bin/hetinv-fig5" $args -o "$work/ref" >"$work/ref.out" 2>&1 || fail "the uninterrupted run failed"
  "$bin/hetinv-fig5" $args -o "$work/run" >"$work/a.out" 2>&1 &
  kill_when "$work/run/checkpoint.bin" $!
  "$bin/hetinv-fig5" $args -o "$work/run" --resume >"$work/b.out" 2>&1 || fail "the --resume run failed"
  same "$work/ref" "$work/run" recovered_sigma_a.vol recovered_sigma_s.vol recovered_g.vol loss.csv errors.csv
  ;;

stage_results_resumed)
  # optimizer.stage_results: stage 1 of 20 iterations ends at iteration
  # 10, where a checkpoint is written before the stage's files are. Their
  # write fails (a folder in the place of stage1_g.vol; a kill there does
  # the same), the run stops with the checkpoint at that iteration; the
  # --resume run must write the stage's files, the uninterrupted run's bytes.
  scene=$src/tests/data/reconstruct/tiny_stage_results.json
  args="$scene --threads 1 --iterations 20 --quiet --no-bound"
  "$bin/hetinv-reconstruct" $args -o "$work/ref" >"$work/ref.out" 2>&1 || fail "the uninterrupted run failed"
  mkdir -p "$work/run/stage1_g.vol/in-the-way"
  if "$bin/hetinv-reconstruct" $args -o "$work/run" >"$work/a.out" 2>&1; then
    fail "the run with stage1_g.vol unwritable succeeded"
  fi
  record_says "$work/run" failed
  rm -r "$work/run/stage1_g.vol"
  "$bin/hetinv-reconstruct" $args -o "$work/run" --resume >"$work/b.out" 2>&1 || fail "the --resume run failed"
  same "$work/ref" "$work/run" stage1_sigma_a.vol stage1_sigma_s.vol stage1_g.vol recovered_sigma_a.vol \
    recovered_g.vol
  ;;

run_record)
  # A render into a folder that holds the user's notes and an older
  # result: the record lists what this run wrote apart from what it found.
  scene=$src/examples/scenes/patterned_camera.json
  mkdir -p "$work/run"
  echo "the user's notes" >"$work/run/notes.txt"
  echo "an older run's image" >"$work/run/old_row.exr"
  touch -d '2001-01-01' "$work/run/notes.txt" "$work/run/old_row.exr"
  "$bin/hetinv-render" "$scene" --photons 200 --threads 1 -o "$work/run" >"$work/a.out" 2>&1 || fail "the render failed"
  record_says "$work/run" complete
  record_lists "$work/run" files front_side.exr front_side_stderr.exr front_side.png
  record_lists "$work/run" older_files notes.txt old_row.exr
  grep -q '"program":[[:space:]]*"hetinv-render"' "$work/run/hetinv-run.json" || fail "the record does not name its program"
  # A hetinv-run.json that is not a run record is the user's: refused, kept.
  mkdir -p "$work/theirs"
  echo '{"runs": 3}' >"$work/theirs/hetinv-run.json"
  if "$bin/hetinv-render" "$scene" --photons 200 --threads 1 -o "$work/theirs" >"$work/b.out" 2>&1; then
    fail "a render over the user's own hetinv-run.json succeeded"
  fi
  grep -q "hetinv-run.json: exists and is not a run record" "$work/b.out" || { fail "no reason given:"; sed 's/^/  | /' "$work/b.out"; }
  [ "$(cat "$work/theirs/hetinv-run.json")" = '{"runs": 3}' ] || fail "the user's hetinv-run.json was changed"
  [ ! -e "$work/theirs/front_side.exr" ] || fail "the refused render wrote images"
  # A FIFO in the record's place would hold a reader forever: refused.
  mkdir -p "$work/fifo"
  mkfifo "$work/fifo/hetinv-run.json"
  timeout 60 "$bin/hetinv-render" "$scene" --photons 200 --threads 1 -o "$work/fifo" >"$work/d.out" 2>&1
  rc=$?
  [ $rc -eq 1 ] || fail "a render over a FIFO named hetinv-run.json: exit status $rc, not 1"
  grep -q "hetinv-run.json: is not a regular file" "$work/d.out" || { fail "no reason given:"; sed 's/^/  | /' "$work/d.out"; }
  # A folder of many older files ("-o ." in a source tree): the record
  # names 1000 of them and counts the rest; it does not walk below the
  # folder's subfolders.
  mkdir -p "$work/many/sub/deeper"
  i=0
  while [ $i -lt 1010 ]; do
    : >"$work/many/f$i"
    i=$((i + 1))
  done
  : >"$work/many/sub/deeper/old.txt"
  touch -d '2001-01-01' "$work"/many/f* "$work/many/sub/deeper/old.txt"
  "$bin/hetinv-render" "$scene" --photons 200 --threads 1 -o "$work/many" >"$work/c.out" 2>&1 || fail "the render failed"
  record_says "$work/many" complete
  grep -q '"older_files_in_all":[[:space:]]*1010' "$work/many/hetinv-run.json" || fail "the record does not count 1010 older files"
  [ "$(grep -o '"f[0-9]*"' "$work/many/hetinv-run.json" | wc -l)" -eq 1000 ] || fail "the record does not name 1000 older files"
  ! grep -q "deeper" "$work/many/hetinv-run.json" || fail "the record walked below a subfolder"
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
