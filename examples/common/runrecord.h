/* The run record of an example program: <folder>/hetinv-run.json.
 *
 * A folder of results should say what made it and whether that run
 * finished. Written when the run starts, with "status": "running", and
 * rewritten (whole, renamed over the old one) when it ends, with
 * "complete" or "failed", so a run killed part-way leaves "running" and
 * the process id of a process that no longer exists: its folder never
 * looks finished, whatever older results lie beside the new ones.
 *
 * The record holds the program, the library's version, the command line,
 * the working folder, the start and end (UTC) and, at the end, the files
 * the run wrote ("files": name and bytes, names relative to the folder,
 * its subfolders' included, not deeper) apart from the files it found
 * there and did not rewrite ("older_files": an earlier run's results, the
 * user's own files; the first 1000 by the directory's order, then their
 * number in "older_files_in_all"). A file counts as written by the run if the file system dated it
 * at or after the record's first write, so no program has to list what it
 * writes. A run resumed from a checkpoint (resume = true) whose record,
 * by the same program, did not end "complete" keeps that record's start:
 * the files its first part wrote stay its own.
 *
 * The end's record is written into a file reserved at the start
 * (RUN_RECORD_RESERVE bytes, then renamed over the record), so a disk that
 * fills during the run fails a result file, named, not the record after
 * the program said "wrote": a full disk is found at the start or at a
 * result. Only a record longer than the reserve (some sixty files) needs
 * more space at the end.
 *
 * Nothing is deleted. A file named hetinv-run.json that is not a run
 * record is refused, not overwritten. Under MPI only the rank that owns
 * the folder calls these. */
#ifndef HETINV_EXAMPLES_RUNRECORD_H
#define HETINV_EXAMPLES_RUNRECORD_H

#include <stdbool.h>
#include <time.h>

/* Name of the record inside an output folder. */
#define RUN_RECORD_NAME "hetinv-run.json"
/* Bytes reserved at the start for the end's record. */
#define RUN_RECORD_RESERVE 4096

typedef struct run_record {
  struct cJSON *root; /* NULL: no record is kept (run_record_begin not called or failed) */
  char *folder;
  const char *prog;
  struct timespec start;      /* the file system's time of the first write */
  struct timespec wall_start; /* this process's start, for "seconds" */
  int reserve_fd;             /* the reserved file of the end's record; -1: none */
  char reserve_tmp[4096 + 32];
} run_record_t;

/* A record not begun: run_record_end on it is a no-op. */
#define RUN_RECORD_INIT {.reserve_fd = -1}

/* Writes the record with "status": "running". argv's strings are copied.
 * Returns 0, or -1 after "<prog>: <file>: <reason>" on stderr. */
int run_record_begin(run_record_t *rec, const char *prog, const char *folder, int argc, char *const *argv,
                     bool resume);

/* Rewrites the record with the run's end: "complete" if exit_status is 0,
 * else "failed" and the status, and the files the run wrote. Frees the
 * record. Returns exit_status, or 1 after a message if the record could
 * not be written (a run whose record is missing must not exit 0). A record
 * never begun is a no-op returning exit_status. */
int run_record_end(run_record_t *rec, int exit_status);

#endif
