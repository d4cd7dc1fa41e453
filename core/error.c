/* Status + message plumbing. */
#include <stdarg.h>
#include <stdio.h>
#include "core/mgs_error.h"

mgs_status mgs_error_set(mgs_error *err, mgs_status code, const char *fmt, ...) {
  if (err) {
    err->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
  }
  return code;
}

void mgs_error_clear(mgs_error *err) {
  if (err) { err->code = MGS_OK; err->msg[0] = '\0'; }
}

const char *mgs_status_name(mgs_status code) {
  switch (code) {
    case MGS_OK: return "ok";
    case MGS_ERR_ARG: return "bad argument";
    case MGS_ERR_IO: return "I/O error";
    case MGS_ERR_FORMAT: return "format error";
    case MGS_ERR_UNSUPPORTED: return "unsupported";
    case MGS_ERR_NOMEM: return "out of memory";
    case MGS_ERR_NUMERIC: return "non-finite value";
    case MGS_ERR_EXISTS: return "output exists";
    case MGS_ERR_INTERRUPTED: return "interrupted";
  }
  return "unknown";
}
