/* Status codes and error messages shared by every module.
 * Library functions never exit(): they return an mgs_status and, when `err` is
 * non-NULL, fill it with a one-line message that names the file and the problem. */
#ifndef MGS_ERROR_H
#define MGS_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum mgs_status {
  MGS_OK = 0,
  MGS_ERR_ARG,         /* bad argument or option value */
  MGS_ERR_IO,          /* file missing, unreadable or unwritable */
  MGS_ERR_FORMAT,      /* malformed or inconsistent file content */
  MGS_ERR_UNSUPPORTED, /* valid input this program does not handle (e.g. camera model) */
  MGS_ERR_NOMEM,       /* allocation failed or request exceeds the memory budget */
  MGS_ERR_NUMERIC,     /* NaN/Inf or a numerically invalid value */
  MGS_ERR_EXISTS,      /* output exists and --force was not given */
  MGS_ERR_INTERRUPTED  /* stopped by the user (Ctrl-C) */
} mgs_status;

#define MGS_ERROR_MSG_MAX 1024

typedef struct mgs_error {
  mgs_status code;
  char msg[MGS_ERROR_MSG_MAX];
} mgs_error;

/* Sets err (if non-NULL) and returns `code`, so callers can `return mgs_error_set(...)`. */
mgs_status mgs_error_set(mgs_error *err, mgs_status code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void mgs_error_clear(mgs_error *err);
const char *mgs_status_name(mgs_status code);

#ifdef __cplusplus
}
#endif
#endif
