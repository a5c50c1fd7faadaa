/* Output folders of the example programs: create, check, lock, clean
 * (see outdir.h for the rules). */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include "outdir.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define OUTDIR_PATH_MAX 4096

static int fail(const char *prog, const char *path, const char *what, int err) {
  fprintf(stderr, "%s: %s: %s%s%s\n", prog, path, what, *what ? ": " : "", strerror(err));
  return -1;
}

static int not_plain(const char *prog, const char *lock, const char *what) {
  fprintf(stderr, "%s: %s: the lock file is %s; remove it (a run writes its process id there)\n", prog, lock, what);
  return -1;
}

/* mkdir -p, then: a folder we may write into. */
static int make_folder(const char *prog, const char *path) {
  char buf[OUTDIR_PATH_MAX];
  if (path[0] == '\0') return fail(prog, "''", "an empty output folder name", ENOENT);
  if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf) return fail(prog, path, "", ENAMETOOLONG);
  for (char *p = buf + 1; *p; ++p) {
    if (*p != '/') continue;
    *p = '\0';
    if (mkdir(buf, 0777) != 0 && errno != EEXIST) return fail(prog, buf, "cannot create the folder", errno);
    *p = '/';
  }
  if (mkdir(buf, 0777) != 0 && errno != EEXIST) return fail(prog, path, "cannot create the folder", errno);
  struct stat st;
  if (stat(path, &st) != 0) return fail(prog, path, "", errno);
  if (!S_ISDIR(st.st_mode)) return fail(prog, path, "exists and is not a folder", ENOTDIR);
  /* Also catches a read-only file system as root (EROFS). */
  if (access(path, W_OK | X_OK) != 0) return fail(prog, path, "cannot write into the output folder", errno);
  return 0;
}

bool outdir_is_temporary(const char *name) {
  static const char tag[] = ".hetinv-tmp-";
  size_t n = strlen(name), t = sizeof tag - 1;
  if (n < t + 7) return false; /* at least one character before the tag */
  if (memcmp(name + n - 6 - t, tag, t) != 0) return false;
  for (size_t i = n - 6; i < n; ++i) {
    char c = name[i];
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9'))) return false;
  }
  return true;
}

/* Removes the regular files of the temporary pattern in a folder the
 * caller has locked (no other run can be writing them). */
static int remove_temporaries(const char *prog, const char *path) {
  DIR *d = opendir(path);
  if (d == NULL) return fail(prog, path, "cannot list the output folder", errno);
  int status = 0;
  char file[OUTDIR_PATH_MAX];
  for (;;) {
    errno = 0;
    struct dirent *e = readdir(d);
    if (e == NULL) {
      if (errno != 0) status = fail(prog, path, "cannot list the output folder", errno);
      break;
    }
    if (!outdir_is_temporary(e->d_name)) continue;
    if (snprintf(file, sizeof file, "%s/%s", path, e->d_name) >= (int)sizeof file) continue;
    struct stat st;
    if (lstat(file, &st) != 0 || !S_ISREG(st.st_mode)) continue;
    if (unlink(file) != 0 && errno != ENOENT) {
      status = fail(prog, file, "cannot remove this temporary file a stopped run left", errno);
      break;
    }
  }
  closedir(d);
  return status;
}

int outdir_prepare(const char *prog, const char *path) {
  if (make_folder(prog, path) != 0) return -1;
  return remove_temporaries(prog, path);
}

int outdir_open(outdir_t *dir, const char *prog, const char *path) {
  dir->lock_fd = -1;
  if (make_folder(prog, path) != 0) return -1;
  char lock[OUTDIR_PATH_MAX];
  if (snprintf(lock, sizeof lock, "%s/%s", path, OUTDIR_LOCK_NAME) >= (int)sizeof lock) {
    return fail(prog, path, "", ENAMETOOLONG);
  }
  /* Never through a link: the pid written below would truncate whatever
   * file a symbolic or hard link there named (outdir.h). */
  int fd = open(lock, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd < 0 && errno == ELOOP) return not_plain(prog, lock, "a symbolic link");
  if (fd < 0) return fail(prog, path, "cannot create the lock file " OUTDIR_LOCK_NAME, errno);
  struct stat st;
  if (fstat(fd, &st) != 0) {
    int err = errno;
    close(fd);
    return fail(prog, lock, "", err);
  }
  if (!S_ISREG(st.st_mode) || st.st_nlink != 1) {
    close(fd);
    return not_plain(prog, lock, S_ISREG(st.st_mode) ? "a file of several hard links" : "not a regular file");
  }
  struct flock fl;
  memset(&fl, 0, sizeof fl);
  fl.l_type = F_WRLCK;
  fl.l_whence = SEEK_SET; /* l_start = l_len = 0: the whole file */
  if (fcntl(fd, F_SETLK, &fl) != 0) {
    int err = errno;
    if (err == EACCES || err == EAGAIN) {
      struct flock who;
      memset(&who, 0, sizeof who);
      who.l_type = F_WRLCK;
      who.l_whence = SEEK_SET;
      char pid[48] = "";
      if (fcntl(fd, F_GETLK, &who) == 0 && who.l_type != F_UNLCK && who.l_pid > 0) {
        snprintf(pid, sizeof pid, " (process %ld)", (long)who.l_pid);
      }
      /* Several copies of a program mpirun started (only hetinv-reconstruct
       * runs as one job over ranks, and only its rank 0 takes the folder). */
      const char *ranks = getenv("OMPI_COMM_WORLD_SIZE");
      if (ranks == NULL) ranks = getenv("PMI_SIZE");
      const bool mpirun = ranks != NULL && atoi(ranks) > 1 && strcmp(prog, "hetinv-reconstruct") != 0;
      fprintf(stderr,
              "%s: %s: the output folder is in use by another run%s; wait for it to end or "
              "choose another folder%s\n",
              prog, path, pid,
              mpirun ? " (started by mpirun with several ranks? of the programs only hetinv-reconstruct "
                       "uses MPI: run this one once, without mpirun)"
                     : "");
    } else {
      fail(prog, path, "cannot lock the output folder (" OUTDIR_LOCK_NAME ")", err);
    }
    close(fd);
    return -1;
  }
  /* The holder's pid, for people looking at the folder; the lock itself is
   * what counts, so a failure here (a full disk) is not an error. */
  char text[32];
  int n = snprintf(text, sizeof text, "%ld\n", (long)getpid());
  if (ftruncate(fd, 0) == 0 && pwrite(fd, text, (size_t)n, 0) == n) {
    /* written */
  }
  dir->lock_fd = fd;
  if (remove_temporaries(prog, path) != 0) {
    outdir_close(dir);
    return -1;
  }
  return 0;
}

void outdir_close(outdir_t *dir) {
  if (dir->lock_fd >= 0) close(dir->lock_fd); /* closing drops the record lock */
  dir->lock_fd = -1;
}

int outdir_finish_stdout(const char *prog) {
  int failed = ferror(stdout) != 0;
  errno = 0;
  if (fflush(stdout) != 0) failed = 1;
  if (!failed) return 0;
  fprintf(stderr, "%s: standard output: %s\n", prog, errno != 0 ? strerror(errno) : "a write failed");
  return 1;
}
