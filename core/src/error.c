/* Thread-local error stack (HDF5 / PETSc style): frames carry code location, message and,
 * for input errors, the place in the scene. */
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

static _Thread_local ej_error_frame ej_frames[EJ_ERROR_MAX_FRAMES];
static _Thread_local int ej_nframes;

static ej_error_frame *ej_error_next(ej_err code)
{
  if (ej_nframes >= EJ_ERROR_MAX_FRAMES) return NULL;
  ej_error_frame *f = &ej_frames[ej_nframes++];
  memset(f, 0, sizeof *f);
  f->code = code;
  return f;
}

/* vsnprintf into a frame's message; a message longer than the frame ends in "..." instead of
 * being cut without a sign */
static void ej_msg_vformat(char *dst, size_t size, const char *fmt, va_list ap)
{
  const int n = vsnprintf(dst, size, fmt, ap);
  if (n >= 0 && (size_t)n >= size && size > 4) memcpy(dst + size - 4, "...", 4);
}

ej_err ej_error_push(ej_err code, const char *file, int line, const char *func, const char *fmt, ...)
{
  ej_error_frame *f = ej_error_next(code);
  if (!f) return code;
  f->file = file;
  f->line = line;
  f->func = func;
  if (fmt) {
    va_list ap;
    va_start(ap, fmt);
    ej_msg_vformat(f->msg, sizeof f->msg, fmt, ap);
    va_end(ap);
  }
  return code;
}

ej_err ej_error_input(const ej_loc *where, const char *fmt, ...)
{
  ej_error_frame *f = ej_error_next(EJ_ERR_INPUT);
  if (!f) return EJ_ERR_INPUT;
  f->file = "input";
  if (where && where->file) {
    snprintf(f->where_file, sizeof f->where_file, "%s", where->file);
    f->where = *where;
    f->where.file = f->where_file;
  }
  va_list ap;
  va_start(ap, fmt);
  ej_msg_vformat(f->msg, sizeof f->msg, fmt, ap);
  va_end(ap);
  return EJ_ERR_INPUT;
}

int ej_error_count(void) { return ej_nframes; }
const ej_error_frame *ej_error_frame_at(int k) { return (k >= 0 && k < ej_nframes) ? &ej_frames[k] : NULL; }

const ej_error_frame *ej_error_cause(void)
{
  for (int k = 0; k < ej_nframes; ++k)
    if (ej_frames[k].msg[0]) return &ej_frames[k];
  return NULL;
}

void ej_error_clear(void) { ej_nframes = 0; }

void ej_error_truncate(int n)
{
  if (n >= 0 && n < ej_nframes) ej_nframes = n;
}

ej_err ej_error_last_code(void) { return ej_nframes ? ej_frames[0].code : EJ_OK; }

void ej_error_import(const ej_error_frame *frames, int n)
{
  for (int k = 0; k < n && ej_nframes < EJ_ERROR_MAX_FRAMES; ++k) {
    ej_frames[ej_nframes] = frames[k];
    if (frames[k].where.file) ej_frames[ej_nframes].where.file = ej_frames[ej_nframes].where_file;
    ++ej_nframes;
  }
}

static const char *ej_err_name(ej_err c)
{
  static const char *names[] = {"ok", "argument", "input", "memory", "i/o", "abi", "plugin", "unsupported",
                                "numeric", "internal"};
  return (c >= 0 && c <= EJ_ERR_INTERNAL) ? names[c] : "unknown";
}

void ej_error_print(FILE *out, const char *prog, bool debug)
{
  const ej_error_frame *cause = ej_error_cause();
  if (!cause) {
    if (ej_nframes) fprintf(out, "%s: error: %s error (no message)\n", prog, ej_err_name(ej_frames[0].code));
    return;
  }
  if (cause->where.file && cause->where.line > 0)
    fprintf(out, "%s:%d:%d: error: %s\n", cause->where.file, cause->where.line, cause->where.col, cause->msg);
  else if (cause->where.file)
    fprintf(out, "%s: error: %s\n", cause->where.file, cause->msg);
  else
    fprintf(out, "%s: error: %s\n", prog, cause->msg);
  bool user = cause->code == EJ_ERR_INPUT || cause->code == EJ_ERR_IO || cause->code == EJ_ERR_ABI ||
              cause->code == EJ_ERR_NUMERIC || cause->code == EJ_ERR_PLUGIN;
  if (debug || !user) {
    for (int k = 0; k < ej_nframes; ++k)
      if (ej_frames[k].func)
        fprintf(out, "  #%d %s() at %s:%d [%s]\n", k, ej_frames[k].func, ej_frames[k].file, ej_frames[k].line,
                ej_err_name(ej_frames[k].code));
  }
}

void ej_error_report(const char *prog)
{
  ej_error_print(stderr, prog, getenv("EJECTA_DEBUG") != NULL);
  ej_error_clear();
}
