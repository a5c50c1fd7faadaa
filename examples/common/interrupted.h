/* What a run stopped by a signal tells its user.
 *
 * Ctrl-C (SIGINT) and a batch system's stop (SIGTERM) end a run at once,
 * as they do by default; the programs' files stay consistent (every output
 * is written whole and renamed, checkpoints likewise) and a rerun
 * continues where the run stopped. interrupted_hint() has the process
 * first print one line on stderr saying how, so that the user does not
 * start over. A signal the process was started with ignored stays ignored
 * (a background job of a non-interactive shell ignores SIGINT). */
#ifndef HETINV_EXAMPLES_INTERRUPTED_H
#define HETINV_EXAMPLES_INTERRUPTED_H

/* Sets the line (a newline is added; longer than 1000 bytes is cut) and
 * installs the handlers; later calls replace the line. */
void interrupted_hint(const char *line);

#endif
