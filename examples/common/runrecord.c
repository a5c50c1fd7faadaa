/* The run record, <folder>/hetinv-run.json (see runrecord.h). */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include "runrecord.h"

#include <dirent.h>
#include <fcntl.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cjson/cJSON.h>
#include <hetinv/version.h>

#include "outdir.h"
#include "textfile.h"

#define RECORD_PATH_MAX 4096
/* An earlier record is read to resume it; a real one is kilobytes. */
#define RECORD_READ_MAX ((long)64 << 20)
/* What the end's listing walks: the folder and its subfolders (hetinv-fig4
 * writes a folder per cell), no deeper, at most RECORD_LIST_MAX files, of
 * which at most RECORD_OLDER_MAX older ones are named: an output folder
 * given as "-o ." in a source tree is not copied into the record. */
#define RECORD_LIST_MAX 100000
#define RECORD_OLDER_MAX 1000
#define RECORD_DEPTH_MAX 1

static int fail(const char *prog, const char *path, const char *what) {
  fprintf(stderr, "%s: %s: %s\n", prog, path, what);
  return -1;
}

/* Drops the record and its reserve: a later run_record_end is a no-op. */
static void forget(run_record_t *rec) {
  cJSON_Delete(rec->root);
  rec->root = NULL;
  free(rec->folder);
  rec->folder = NULL;
  if (rec->reserve_fd >= 0) {
    close(rec->reserve_fd);
    unlink(rec->reserve_tmp);
    rec->reserve_fd = -1;
  }
}

/* The end's record file, "<path>.hetinv-tmp-XXXXXX" (removed by the next
 * run's outdir_open if this one is killed), with its bytes allocated. */
static int reserve(run_record_t *rec, const char *path) {
  if (snprintf(rec->reserve_tmp, sizeof rec->reserve_tmp, "%s.hetinv-tmp-XXXXXX", path) >=
      (int)sizeof rec->reserve_tmp)
    return fail(rec->prog, path, strerror(ENAMETOOLONG));
  int fd = mkstemp(rec->reserve_tmp);
  if (fd < 0) return fail(rec->prog, path, strerror(errno));
  fchmod(fd, 0644);
  rec->reserve_fd = fd;
  int err = posix_fallocate(fd, 0, RUN_RECORD_RESERVE);
  if (err != 0) {
    char why[160];
    snprintf(why, sizeof why, "cannot reserve %d bytes for the run record's end: %s", RUN_RECORD_RESERVE,
             strerror(err));
    return fail(rec->prog, path, why);
  }
  return 0;
}

/* The end's record into the reserved file, renamed over the record. */
static int write_reserved(run_record_t *rec, const char *path) {
  char *text = cJSON_Print(rec->root);
  if (text == NULL) return fail(rec->prog, path, strerror(ENOMEM));
  size_t n = strlen(text);
  text[n++] = '\n'; /* over the terminator: the file is not a C string */
  int fd = rec->reserve_fd, err = 0;
  for (size_t done = 0; done < n && err == 0;) {
    ssize_t w = pwrite(fd, text + done, n - done, (off_t)done);
    if (w < 0 && errno != EINTR) err = errno;
    if (w > 0) done += (size_t)w;
  }
  free(text);
  if (err == 0 && (ftruncate(fd, (off_t)n) != 0 || fsync(fd) != 0)) err = errno;
  if (close(fd) != 0 && err == 0) err = errno;
  rec->reserve_fd = -1;
  if (err == 0 && rename(rec->reserve_tmp, path) != 0) err = errno;
  if (err != 0) {
    unlink(rec->reserve_tmp);
    return fail(rec->prog, path, strerror(err));
  }
  return 0;
}

static void iso_utc(const struct timespec *t, char out[32]) {
  struct tm tm;
  time_t s = t->tv_sec;
  if (gmtime_r(&s, &tm) == NULL || strftime(out, 32, "%Y-%m-%dT%H:%M:%SZ", &tm) == 0) snprintf(out, 32, "?");
}

static bool at_or_after(const struct timespec *a, const struct timespec *b) {
  return a->tv_sec > b->tv_sec || (a->tv_sec == b->tv_sec && a->tv_nsec >= b->tv_nsec);
}

/* The existing record at path: 1 and *out if it is a run record, 0 if
 * there is none, -1 after a message (unreadable, or not a record). */
static int read_record(const char *prog, const char *path, cJSON **out) {
  *out = NULL;
  struct stat st;
  /* lstat first: opening a FIFO would wait for a writer. */
  if (lstat(path, &st) != 0) return errno == ENOENT ? 0 : fail(prog, path, strerror(errno));
  if (!S_ISREG(st.st_mode)) return fail(prog, path, "is not a regular file; the run record is written there");
  FILE *f = fopen(path, "rb");
  if (f == NULL) return fail(prog, path, strerror(errno));
  char *text = NULL;
  int status = -1;
  if (fstat(fileno(f), &st) != 0) {
    fail(prog, path, strerror(errno));
  } else if (!S_ISREG(st.st_mode)) {
    fail(prog, path, "is not a regular file; the run record is written there");
  } else if (st.st_size > RECORD_READ_MAX) {
    fail(prog, path, "is larger than 64 MiB and so not a run record; move it away");
  } else if ((text = malloc((size_t)st.st_size + 1)) == NULL) {
    fail(prog, path, strerror(ENOMEM));
  } else if (fread(text, 1, (size_t)st.st_size, f) != (size_t)st.st_size) {
    fail(prog, path, ferror(f) ? strerror(EIO) : "changed while it was read");
  } else {
    cJSON *root = cJSON_ParseWithLength(text, (size_t)st.st_size);
    if (!cJSON_IsObject(root) || !cJSON_IsNumber(cJSON_GetObjectItemCaseSensitive(root, "hetinv_run"))) {
      cJSON_Delete(root);
      fail(prog, path, "exists and is not a run record of these programs (no \"hetinv_run\"); move it away");
    } else {
      *out = root;
      status = 1;
    }
  }
  free(text);
  fclose(f);
  return status;
}

static int write_record(const run_record_t *rec, const char *path) {
  char *text = cJSON_Print(rec->root);
  if (text == NULL) return fail(rec->prog, path, strerror(ENOMEM));
  char tmp[RECORD_PATH_MAX + 32];
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  int status = 0;
  if (f == NULL) {
    status = fail(rec->prog, path, strerror(errno));
  } else {
    fprintf(f, "%s\n", text);
    if (text_file_commit(f, tmp, path) != 0) status = fail(rec->prog, path, strerror(errno));
  }
  free(text);
  return status;
}

static void set_item(cJSON *root, const char *key, cJSON *item) {
  if (item == NULL) return;
  if (cJSON_GetObjectItemCaseSensitive(root, key) != NULL) {
    cJSON_ReplaceItemInObjectCaseSensitive(root, key, item);
  } else {
    cJSON_AddItemToObject(root, key, item);
  }
}

/* The earlier record's start, if this run resumes it: same program, not
 * complete, a start it can read. */
static bool resumable(const cJSON *old, const char *prog, struct timespec *start) {
  const cJSON *program = cJSON_GetObjectItemCaseSensitive(old, "program");
  const cJSON *status = cJSON_GetObjectItemCaseSensitive(old, "status");
  const cJSON *sec = cJSON_GetObjectItemCaseSensitive(old, "start_file_time_s");
  const cJSON *nsec = cJSON_GetObjectItemCaseSensitive(old, "start_file_time_ns");
  if (!cJSON_IsString(program) || strcmp(program->valuestring, prog) != 0) return false;
  if (cJSON_IsString(status) && strcmp(status->valuestring, "complete") == 0) return false;
  if (!cJSON_IsNumber(sec) || !cJSON_IsNumber(nsec) || !(sec->valuedouble >= 0.0) || !(sec->valuedouble < 1e15) ||
      !(nsec->valuedouble >= 0.0) || !(nsec->valuedouble < 1e9))
    return false;
  start->tv_sec = (time_t)sec->valuedouble;
  start->tv_nsec = (long)nsec->valuedouble;
  return true;
}

int run_record_begin(run_record_t *rec, const char *prog, const char *folder, int argc, char *const *argv,
                     bool resume) {
  memset(rec, 0, sizeof *rec);
  rec->reserve_fd = -1;
  rec->prog = prog;
  clock_gettime(CLOCK_REALTIME, &rec->wall_start);
  char path[RECORD_PATH_MAX];
  if (snprintf(path, sizeof path, "%s/%s", folder, RUN_RECORD_NAME) >= (int)sizeof path)
    return fail(prog, folder, strerror(ENAMETOOLONG));
  cJSON *old = NULL;
  if (read_record(prog, path, &old) < 0) return -1;
  struct timespec start;
  bool resumed = resume && old != NULL && resumable(old, prog, &start);
  int resumes = 0;
  const cJSON *old_resumes = cJSON_GetObjectItemCaseSensitive(old, "resumes");
  if (resumed && cJSON_IsNumber(old_resumes) && old_resumes->valuedouble >= 0 && old_resumes->valuedouble < 1e6)
    resumes = (int)old_resumes->valuedouble;
  cJSON *root = cJSON_CreateObject();
  rec->root = root;
  rec->folder = strdup(folder);
  if (root == NULL || rec->folder == NULL) {
    cJSON_Delete(old);
    forget(rec);
    return fail(prog, path, strerror(ENOMEM));
  }
  char cwd[RECORD_PATH_MAX], when[32];
  cJSON_AddNumberToObject(root, "hetinv_run", 1);
  cJSON_AddStringToObject(root, "program", prog);
  cJSON_AddStringToObject(root, "library_version", hetinv_version_string());
  cJSON *command = cJSON_AddArrayToObject(root, "command");
  for (int i = 0; i < argc && command != NULL; ++i) cJSON_AddItemToArray(command, cJSON_CreateString(argv[i]));
  cJSON_AddStringToObject(root, "working_folder", getcwd(cwd, sizeof cwd) ? cwd : "?");
  cJSON_AddNumberToObject(root, "pid", (double)getpid());
  cJSON_AddStringToObject(root, "status", "running");
  if (resumed) {
    const cJSON *started = cJSON_GetObjectItemCaseSensitive(old, "started");
    cJSON_AddStringToObject(root, "started", cJSON_IsString(started) ? started->valuestring : "?");
    cJSON_AddNumberToObject(root, "resumes", resumes + 1);
  } else {
    iso_utc(&rec->wall_start, when);
    cJSON_AddStringToObject(root, "started", when);
  }
  cJSON_Delete(old);
  if (reserve(rec, path) != 0) {
    forget(rec);
    return -1;
  }
  if (resumed) {
    rec->start = start;
  } else {
    /* The file system's own clock, the one that dates the run's files:
     * the reserve was just created. */
    struct stat st;
    if (fstat(rec->reserve_fd, &st) != 0) {
      forget(rec);
      return fail(prog, path, strerror(errno));
    }
    rec->start = st.st_mtim;
  }
  cJSON_AddNumberToObject(root, "start_file_time_s", (double)rec->start.tv_sec);
  cJSON_AddNumberToObject(root, "start_file_time_ns", (double)rec->start.tv_nsec);
  if (write_record(rec, path) != 0) {
    forget(rec);
    return -1;
  }
  return 0;
}

typedef struct listing {
  cJSON *written, *older;
  int count, older_count;
  bool truncated;
} listing_t;

/* Adds the regular files under folder/rel (rel "" for the folder itself)
 * to the listing, by the run's start. */
static void list_files(const run_record_t *rec, const char *rel, int depth, listing_t *out) {
  char dir[RECORD_PATH_MAX], file[RECORD_PATH_MAX], name[RECORD_PATH_MAX];
  if (snprintf(dir, sizeof dir, "%s%s%s", rec->folder, *rel ? "/" : "", rel) >= (int)sizeof dir) return;
  DIR *d = opendir(dir);
  if (d == NULL) return;
  struct dirent *e;
  while ((e = readdir(d)) != NULL) {
    if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
    if (*rel == '\0' && (strcmp(e->d_name, RUN_RECORD_NAME) == 0 || strcmp(e->d_name, OUTDIR_LOCK_NAME) == 0))
      continue;
    if (outdir_is_temporary(e->d_name)) continue;
    if (snprintf(file, sizeof file, "%s/%s", dir, e->d_name) >= (int)sizeof file) continue;
    if (snprintf(name, sizeof name, "%s%s%s", rel, *rel ? "/" : "", e->d_name) >= (int)sizeof name) continue;
    struct stat st;
    if (lstat(file, &st) != 0) continue;
    if (S_ISDIR(st.st_mode)) {
      if (depth < RECORD_DEPTH_MAX) list_files(rec, name, depth + 1, out);
      continue;
    }
    if (!S_ISREG(st.st_mode)) continue;
    if (out->count >= RECORD_LIST_MAX) {
      out->truncated = true;
      continue;
    }
    out->count++;
    if (at_or_after(&st.st_mtim, &rec->start)) {
      cJSON *entry = cJSON_CreateObject();
      cJSON_AddStringToObject(entry, "name", name);
      cJSON_AddNumberToObject(entry, "bytes", (double)st.st_size);
      cJSON_AddItemToArray(out->written, entry);
    } else if (out->older_count++ < RECORD_OLDER_MAX) {
      cJSON_AddItemToArray(out->older, cJSON_CreateString(name));
    }
  }
  closedir(d);
}

/* Orders a list of files, or of names, by name: the listing follows the
 * directory's order, which differs between two identical runs. */
static int by_name(const void *a, const void *b) {
  const cJSON *x = *(const cJSON *const *)a, *y = *(const cJSON *const *)b;
  if (cJSON_IsObject(x)) x = cJSON_GetObjectItemCaseSensitive(x, "name");
  if (cJSON_IsObject(y)) y = cJSON_GetObjectItemCaseSensitive(y, "name");
  return strcmp(cJSON_GetStringValue(x), cJSON_GetStringValue(y));
}

static cJSON *sorted(cJSON *array) {
  int n = cJSON_GetArraySize(array);
  cJSON **items = n > 0 ? malloc((size_t)n * sizeof *items) : NULL;
  if (items == NULL) return array;
  for (int i = n - 1; i >= 0; --i) items[i] = cJSON_DetachItemFromArray(array, i);
  qsort(items, (size_t)n, sizeof *items, by_name);
  for (int i = 0; i < n; ++i) cJSON_AddItemToArray(array, items[i]);
  free(items);
  return array;
}

int run_record_end(run_record_t *rec, int exit_status) {
  if (rec->root == NULL) {
    forget(rec);
    return exit_status;
  }
  struct timespec now;
  clock_gettime(CLOCK_REALTIME, &now);
  char when[32], path[RECORD_PATH_MAX];
  iso_utc(&now, when);
  cJSON *root = rec->root;
  set_item(root, "status", cJSON_CreateString(exit_status == 0 ? "complete" : "failed"));
  if (exit_status != 0) set_item(root, "exit_status", cJSON_CreateNumber(exit_status));
  set_item(root, "finished", cJSON_CreateString(when));
  double seconds = (double)(now.tv_sec - rec->wall_start.tv_sec) + 1e-9 * (double)(now.tv_nsec - rec->wall_start.tv_nsec);
  set_item(root, "seconds", cJSON_CreateNumber(seconds));
  listing_t files = {cJSON_CreateArray(), cJSON_CreateArray(), 0, 0, false};
  if (files.written != NULL && files.older != NULL) list_files(rec, "", 0, &files);
  set_item(root, "files", sorted(files.written));
  set_item(root, "older_files", sorted(files.older));
  if (files.older_count > RECORD_OLDER_MAX) set_item(root, "older_files_in_all", cJSON_CreateNumber(files.older_count));
  if (files.truncated) set_item(root, "files_listed_at_most", cJSON_CreateNumber(RECORD_LIST_MAX));
  int status = exit_status;
  if (snprintf(path, sizeof path, "%s/%s", rec->folder, RUN_RECORD_NAME) >= (int)sizeof path ||
      write_reserved(rec, path) != 0) {
    if (status == 0) status = 1;
  }
  forget(rec);
  return status;
}
