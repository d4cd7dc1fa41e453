/* File-system helpers: atomic writes (temp file + rename), directory creation, and the
 * "never overwrite what the user had" checks. */
#ifndef MGS_FS_H
#define MGS_FS_H
#include <stddef.h>
#include <stdio.h>
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Atomic file: write to the returned FILE*, then commit (fsync + rename onto `path`) or
 * abort (remove the temporary). */
typedef struct mgs_atomic_file mgs_atomic_file;
mgs_status mgs_atomic_open(const char *path, mgs_atomic_file **out, FILE **fp, mgs_error *err);
mgs_status mgs_atomic_commit(mgs_atomic_file *af, mgs_error *err);
void mgs_atomic_abort(mgs_atomic_file *af);
/* Writes a whole buffer atomically. */
mgs_status mgs_write_file_atomic(const char *path, const void *data, size_t size, mgs_error *err);
/* Reads a whole file (NUL-terminated for text use); *size excludes the NUL. */
mgs_status mgs_read_file(const char *path, char **data, size_t *size, mgs_error *err);
/* A temporary path beside `path` (same directory, so rename is atomic). Caller frees. */
char *mgs_temp_path_for(const char *path);

/* mkdir -p */
mgs_status mgs_mkdir_p(const char *dir, mgs_error *err);
int mgs_path_exists(const char *path);
int mgs_is_dir(const char *path);
/* Removes a directory tree (used to drop a staging directory). */
mgs_status mgs_remove_tree(const char *path, mgs_error *err);
/* Joins a and b with '/', caller frees. */
char *mgs_path_join(const char *a, const char *b);
/* Directory part of a path ("." if none), caller frees. */
char *mgs_path_dirname(const char *path);
char *mgs_strdup(const char *s);

#ifdef __cplusplus
}
#endif
#endif
