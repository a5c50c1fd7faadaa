/* The output folder of an example program, and its standard output.
 *
 * A program opens its folder before any simulation (outdir_open): the
 * folder is created if missing and must be a folder it can write to, so a
 * bad -o fails at once instead of after hours of work. It is then locked
 * for the run: <folder>/.hetinv.lock holds an exclusive POSIX record lock
 * (fcntl F_SETLK, not waiting), so a second run on the same folder stops
 * at once with a message naming the folder and the holder's process
 * instead of mixing its files with the first one's. The kernel drops the
 * lock when the process ends, killed or not, so a crash never leaves the
 * folder locked and a later run (hetinv-reconstruct --resume included)
 * takes it again. The lock file stays (its text is the holder's pid):
 * deleting it would let a third run lock a new file while a second still
 * held the old one.
 *
 * Temporaries: every output file is written as "<name>.hetinv-tmp-XXXXXX"
 * (six letters or digits: the library's atomic writer, and
 * text_file_begin) and renamed over <name> once complete; a process
 * killed in between leaves that file behind. Once the folder is locked no
 * other run of ours writes there, so every regular file of that pattern is
 * such a leftover: outdir_open and outdir_prepare remove them. The tag
 * names the library, so another program's temporaries (an editor's
 * "x.tmp-Ab12Cd" in a folder given as -o .) are never matched.
 *
 * The lock file must be a regular file of one link: a symbolic or hard
 * link there would make the run overwrite the file it points to.
 *
 * Failures print "<prog>: <folder or file>: <reason>" on stderr. */
#ifndef HETINV_EXAMPLES_OUTDIR_H
#define HETINV_EXAMPLES_OUTDIR_H

#include <stdbool.h>

/* Name of the lock file inside an output folder. */
#define OUTDIR_LOCK_NAME ".hetinv.lock"

typedef struct outdir {
  int lock_fd; /* -1: not locked */
} outdir_t;

/* Creates `path` (with its parents) if missing, checks that it is a folder
 * this process can write to, locks it for the life of the process (or
 * until outdir_close) and removes stale temporaries. -1 after a message. */
int outdir_open(outdir_t *dir, const char *prog, const char *path);

/* Releases the lock (the lock file stays). */
void outdir_close(outdir_t *dir);

/* A folder inside a locked one (hetinv-fig4's per-run folders): created if
 * missing, checked, cleared of stale temporaries. -1 after a message. */
int outdir_prepare(const char *prog, const char *path);

/* true if `name` has the pattern of a temporary output file,
 * "<something>.hetinv-tmp-XXXXXX" with six letters or digits. */
bool outdir_is_temporary(const char *name);

/* Flushes standard output and checks that everything written to it
 * arrived (a full disk or a closed pipe makes printf fail silently).
 * Returns 0, or 1 after "<prog>: standard output: <reason>": a program
 * returns this so that its exit status reports output it could not write. */
int outdir_finish_stdout(const char *prog);

#endif
