/* Allocation through the core (accounting, one heap across DSOs) and small text utilities. */
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "core_impl.h"

void *ej_malloc(size_t size) { return malloc(size ? size : 1); }

void *ej_calloc(size_t n, size_t size)
{
  if (size && n > SIZE_MAX / size) return NULL;
  return calloc(n ? n : 1, size ? size : 1);
}

void *ej_realloc(void *p, size_t size) { return realloc(p, size ? size : 1); }
void ej_free(void *p) { free(p); }

char *ej_strdup(const char *s)
{
  if (!s) return NULL;
  size_t n = strlen(s) + 1;
  char *d = ej_malloc(n);
  if (d) memcpy(d, s, n);
  return d;
}

char *ej_path_beside(const char *file, const char *name)
{
  const char *slash = file && name[0] != '/' ? strrchr(file, '/') : NULL;
  const size_t nd = slash ? (size_t)(slash - file) + 1 : 0, nn = strlen(name);
  char *p = ej_malloc(nd + nn + 1);
  if (!p) return NULL;
  if (nd) memcpy(p, file, nd); /* file may be NULL (nd = 0): no memcpy from a null pointer */
  memcpy(p + nd, name, nn + 1);
  return p;
}

ej_err ej_buf_printf(ej_buf *b, const char *fmt, ...)
{
  va_list ap;
  va_start(ap, fmt);
  int need = vsnprintf(NULL, 0, fmt, ap);
  va_end(ap);
  EJ_ENSURE(need >= 0, EJ_ERR_INTERNAL, "bad format");
  if (b->len + (size_t)need + 1 > b->cap) {
    size_t cap = b->cap ? b->cap : 256;
    while (cap < b->len + (size_t)need + 1) cap *= 2;
    char *d = ej_realloc(b->data, cap);
    EJ_ENSURE(d, EJ_ERR_MEM, "out of memory");
    b->data = d;
    b->cap = cap;
  }
  va_start(ap, fmt);
  vsnprintf(b->data + b->len, (size_t)need + 1, fmt, ap);
  va_end(ap);
  b->len += (size_t)need;
  return EJ_OK;
}

void ej_buf_free(ej_buf *b)
{
  if (!b) return;
  ej_free(b->data);
  b->data = NULL;
  b->len = b->cap = 0;
}

int ej_edit_distance(const char *a, const char *b)
{
  size_t la = strlen(a), lb = strlen(b);
  if (la > 64 || lb > 64) return 1000;
  int row[65];
  for (size_t j = 0; j <= lb; ++j) row[j] = (int)j;
  for (size_t i = 1; i <= la; ++i) {
    int diag = row[0];
    row[0] = (int)i;
    for (size_t j = 1; j <= lb; ++j) {
      int up = row[j];
      int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      int best = diag + cost;
      if (row[j] + 1 < best) best = row[j] + 1;
      if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
      row[j] = best;
      diag = up;
    }
  }
  return row[lb];
}

const char *ej_nearest_word(const char *word, const char *const *cands, int n)
{
  const char *best = NULL;
  int bestd = 1000;
  for (int i = 0; i < n; ++i) {
    if (!cands[i]) continue;
    int d = ej_edit_distance(word, cands[i]);
    if (d < bestd) {
      bestd = d;
      best = cands[i];
    }
  }
  size_t len = strlen(word);
  int limit = len <= 4 ? 2 : (int)(len / 2);
  return bestd <= limit ? best : NULL;
}
