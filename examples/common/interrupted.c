#include "interrupted.h"

#include <signal.h>
#include <string.h>
#include <unistd.h>

/* The handler may call only async-signal-safe functions (write, raise,
 * sigaction): the line is formatted beforehand. */
static char hint[1024];
static volatile sig_atomic_t hint_length;

static void on_stop(int sig) {
  if (hint_length > 0) {
    ssize_t ignored = write(STDERR_FILENO, hint, (size_t)hint_length);
    (void)ignored; /* nothing to do if stderr is gone */
  }
  /* SA_RESETHAND restored the default action: the signal, raised again,
   * ends the process as it would have, once this handler returns. */
  raise(sig);
}

void interrupted_hint(const char *line) {
  /* On a terminal the line starts on its own: a progress line may be
   * half-written there (rewritten in place with '\r'), and Ctrl-C echoes. */
  size_t at = isatty(STDERR_FILENO) ? 1 : 0;
  size_t n = strlen(line);
  if (n > sizeof hint - 2 - at) n = sizeof hint - 2 - at;
  hint_length = 0;
  hint[0] = '\n';
  memcpy(hint + at, line, n);
  hint[at + n] = '\n';
  hint_length = (sig_atomic_t)(at + n + 1);
  static const int SIGNALS[] = {SIGINT, SIGTERM};
  for (size_t i = 0; i < sizeof SIGNALS / sizeof SIGNALS[0]; ++i) {
    struct sigaction old;
    if (sigaction(SIGNALS[i], NULL, &old) != 0 || old.sa_handler == SIG_IGN) continue;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop;
    sa.sa_flags = SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGNALS[i], &sa, NULL);
  }
}
