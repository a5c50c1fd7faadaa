/* A text output written whole or not at all, as the library writes its
 * files: text_file_begin() creates "<path>.hetinv-tmp-XXXXXX" (tmp
 * receives that name; NULL with errno set on failure; the pattern
 * outdir.h removes when a killed run left one), and text_file_commit()
 * flushes it to disk, closes it and renames it over path, or removes it
 * if anything failed (-1, errno set). */
#ifndef HETINV_EXAMPLES_TEXTFILE_H
#define HETINV_EXAMPLES_TEXTFILE_H

#include <stddef.h>
#include <stdio.h>

FILE *text_file_begin(const char *path, char *tmp, size_t tmp_size);
int text_file_commit(FILE *f, const char *tmp, const char *path);

#endif
