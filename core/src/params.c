/* Parameter tables (ej_param) drive three things from one declaration: YAML validation with
 * file:line:column, the human-readable `ejecta describe` listing and the JSON Schema.
 *
 * Defaults and bounds in a table are written in the declared unit (for "deg": degrees);
 * configs always hold SI values (radians for angles). */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "units_impl.h"

#define EJ_WHAT_LEN 256

static const char *ej_param_unit(const ej_param *p) { return p->unit ? p->unit : "1"; }

static bool ej_unit_is_plain(const char *unit) { return strcmp(unit, "1") == 0; }

static double ej_param_scale(const ej_param *p)
{
  double s = 1;
  if (!ej_units_scale(ej_param_unit(p), &s)) s = 1;
  return s;
}

static int ej_param_count(const ej_param *table)
{
  int n = 0;
  while (table && table[n].name) ++n;
  return n;
}

static const ej_param *ej_param_find(const ej_param *table, const char *name)
{
  for (const ej_param *p = table; p && p->name; ++p)
    if (strcmp(p->name, name) == 0) return p;
  return NULL;
}

static int ej_enum_index(const char *const *choices, const char *word)
{
  for (int i = 0; choices && choices[i]; ++i)
    if (strcmp(choices[i], word) == 0) return i;
  return -1;
}

/* "a, b, c" (sep between items) into buf. */
static void ej_join(char *buf, size_t size, const char *const *words, int n, const char *sep)
{
  size_t len = 0;
  buf[0] = '\0';
  for (int i = 0; i < n && len < size; ++i) {
    if (!words[i]) continue;
    len += (size_t)snprintf(buf + len, size - len, "%s%s", len ? sep : "", words[i]);
  }
}

static int ej_choice_count(const char *const *choices)
{
  int n = 0;
  while (choices && choices[n]) ++n;
  return n;
}

/* ------------------------------------------------------------------ defaults */

ej_err ej_params_defaults(const ej_param *table, void *config)
{
  EJ_ENSURE(config || !ej_param_count(table), EJ_ERR_ARG, "NULL config");
  for (const ej_param *p = table; p && p->name; ++p) {
    char *field = (char *)config + p->offset;
    switch (p->type) {
    case EJ_PT_REAL: *(ej_real *)field = p->def * ej_param_scale(p); break;
    case EJ_PT_INT: *(int64_t *)field = (int64_t)p->def; break;
    case EJ_PT_BOOL: *(bool *)field = p->def != 0; break;
    case EJ_PT_ENUM: {
      int k = p->def_str ? ej_enum_index(p->choices, p->def_str) : 0;
      EJ_ENSURE(k >= 0, EJ_ERR_PLUGIN, "parameter '%s': default '%s' is not one of its choices", p->name,
                p->def_str);
      *(int *)field = k;
      break;
    }
    case EJ_PT_STRING: *(const char **)field = p->def_str; break;
    case EJ_PT_REAL_ARRAY: memset(field, 0, (size_t)(p->count > 0 ? p->count : 0) * sizeof(ej_real)); break;
    case EJ_PT_BLOCK: EJ_TRY(ej_params_defaults(p->sub, field)); break;
    default: EJ_FAIL(EJ_ERR_PLUGIN, "parameter '%s' has unknown type %d", p->name, (int)p->type);
    }
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ validation */

static const char *ej_param_expected(const ej_param *p, char *buf, size_t size)
{
  const char *unit = ej_param_unit(p);
  switch (p->type) {
  case EJ_PT_REAL:
    if (ej_unit_is_plain(unit)) return "a number";
    snprintf(buf, size, "a number (%s)", unit);
    return buf;
  case EJ_PT_INT: return "an integer";
  case EJ_PT_BOOL: return "true or false";
  case EJ_PT_ENUM: {
    char list[256];
    ej_join(list, sizeof list, p->choices, ej_choice_count(p->choices), ", ");
    snprintf(buf, size, "one of %s", list);
    return buf;
  }
  case EJ_PT_STRING: return "a text";
  case EJ_PT_REAL_ARRAY: snprintf(buf, size, "a list of %d numbers", p->count); return buf;
  case EJ_PT_BLOCK: return "a mapping";
  }
  return "a value";
}

static const char *ej_node_what(const ej_node *n, char *buf, size_t size)
{
  if (n->type == EJ_NODE_MAP) return "a mapping";
  if (n->type == EJ_NODE_SEQ) return "a list";
  /* a long value is cut at 60 characters, and the message says so and how long it was */
  const size_t len = strlen(n->text);
  if (len > 64)
    snprintf(buf, size, n->quoted ? "a quoted string \"%.60s...\" (%zu characters)" : "'%.60s...' (%zu characters)",
             n->text, len);
  else
    snprintf(buf, size, n->quoted ? "a quoted string \"%s\"" : "'%s'", n->text);
  return buf;
}

static ej_err ej_wrong_type(const ej_param *p, const ej_node *v, const char *what)
{
  char eb[320], gb[128];
  return ej_error_input(&v->loc, "'%s' in %s must be %s, got %s", p->name, what, ej_param_expected(p, eb, sizeof eb),
                        ej_node_what(v, gb, sizeof gb));
}

/* "[0, 1]", "(0, inf)" in the declared unit. */
static void ej_param_range(const ej_param *p, char *buf, size_t size)
{
  char lo[32] = "-inf", hi[32] = "inf";
  if (p->flags & EJ_PF_HAS_MIN) snprintf(lo, sizeof lo, "%g", p->min);
  if (p->flags & EJ_PF_HAS_MAX) snprintf(hi, sizeof hi, "%g", p->max);
  bool lo_open = !(p->flags & EJ_PF_HAS_MIN) || (p->flags & EJ_PF_MIN_OPEN);
  bool hi_open = !(p->flags & EJ_PF_HAS_MAX) || (p->flags & EJ_PF_MAX_OPEN);
  const char *unit = ej_param_unit(p);
  snprintf(buf, size, "%c%s, %s%c%s%s", lo_open ? '(' : '[', lo, hi, hi_open ? ')' : ']',
           ej_unit_is_plain(unit) ? "" : " ", ej_unit_is_plain(unit) ? "" : unit);
}

/* Bounds are compared in SI so that "90 deg" against max 90 (deg) is not lost to rounding. */
static ej_err ej_param_bounds(const ej_param *p, double v, double scale, const char *text, const ej_loc *loc,
                              const char *what)
{
  bool bad = false;
  if (p->flags & EJ_PF_HAS_MIN) {
    double m = p->min * scale;
    bad = bad || ((p->flags & EJ_PF_MIN_OPEN) ? !(v > m) : !(v >= m));
  }
  if (p->flags & EJ_PF_HAS_MAX) {
    double m = p->max * scale;
    bad = bad || ((p->flags & EJ_PF_MAX_OPEN) ? !(v < m) : !(v <= m));
  }
  if (!bad) return EJ_OK;
  char range[96];
  ej_param_range(p, range, sizeof range);
  return ej_error_input(loc, "'%s' = %s is out of range %s in %s", p->name, text, range, what);
}

static ej_err ej_param_real(const ej_param *p, const ej_node *v, const char *what, const char *subject,
                            ej_real *out)
{
  if (v->type != EJ_NODE_SCALAR || v->quoted) {
    char gb[128];
    const char *unit = ej_param_unit(p);
    return ej_error_input(&v->loc, "%s must be a number%s%s%s, got %s", subject, ej_unit_is_plain(unit) ? "" : " (",
                          ej_unit_is_plain(unit) ? "" : unit, ej_unit_is_plain(unit) ? "" : ")",
                          ej_node_what(v, gb, sizeof gb));
  }
  double si = 0;
  EJ_TRY(ej_units_parse_as(v->text, ej_param_unit(p), &v->loc, subject, &si));
  EJ_TRY(ej_param_bounds(p, si, ej_param_scale(p), v->text, &v->loc, what));
  *out = si;
  return EJ_OK;
}

static bool ej_parse_int(const char *s, int64_t *out)
{
  while (isspace((unsigned char)*s)) ++s;
  const char *d = s;
  if (*d == '+' || *d == '-') ++d;
  if (!isdigit((unsigned char)*d)) return false;
  errno = 0;
  char *end = NULL;
  long long v = strtoll(s, &end, 10);
  if (errno == ERANGE) return false;
  while (isspace((unsigned char)*end)) ++end;
  if (*end) return false;
  *out = (int64_t)v;
  return true;
}

static bool ej_same_word_nocase(const char *a, const char *b)
{
  for (; *a && *b; ++a, ++b)
    if (tolower((unsigned char)*a) != tolower((unsigned char)*b)) return false;
  return *a == *b;
}

/* YAML 1.1 booleans, as users of other YAML tools write them (True, yes, off, ...). */
static bool ej_parse_bool(const char *s, bool *out)
{
  static const char *yes[] = {"true", "yes", "on"}, *no[] = {"false", "no", "off"};
  for (int i = 0; i < 3; ++i) {
    if (ej_same_word_nocase(s, yes[i])) return *out = true, true;
    if (ej_same_word_nocase(s, no[i])) return *out = false, true;
  }
  return false;
}

/* EJ_PF_PATH: a relative path is taken from the directory of the file that holds the value (the
 * node's text is replaced once: the doc owns it, and a second apply of the same node sees the
 * resolved path), and the file must open for reading. */
static ej_err ej_param_path(ej_node *v, const char *subject)
{
  if (!v->path_resolved) {
    char *t = ej_path_beside(v->loc.file, v->text);
    EJ_ENSURE(t, EJ_ERR_MEM, "out of memory");
    ej_free(v->text);
    v->text = t;
  }
  v->path_resolved = true;
  FILE *f = fopen(v->text, "r");
  if (!f) return ej_error_input(&v->loc, "%s: cannot read file '%s' (%s)", subject, v->text, strerror(errno));
  fclose(f);
  return EJ_OK;
}

static ej_err ej_param_value(const ej_param *p, void *config, const ej_node *v, const char *what)
{
  char *field = (char *)config + p->offset;
  char subject[EJ_WHAT_LEN + 64];
  snprintf(subject, sizeof subject, "'%s' in %s", p->name, what);
  /* "key:" with nothing after it is YAML null: say so rather than "got ''". */
  if (v->type == EJ_NODE_SCALAR && !v->quoted && v->text[0] == '\0') {
    char eb[320];
    return ej_error_input(&v->loc, "%s has no value; expected %s", subject, ej_param_expected(p, eb, sizeof eb));
  }
  switch (p->type) {
  case EJ_PT_REAL: EJ_TRY(ej_param_real(p, v, what, subject, (ej_real *)field)); return EJ_OK;
  case EJ_PT_INT: {
    int64_t k = 0;
    if (v->type != EJ_NODE_SCALAR || v->quoted || !ej_parse_int(v->text, &k)) return ej_wrong_type(p, v, what);
    EJ_TRY(ej_param_bounds(p, (double)k, 1, v->text, &v->loc, what));
    *(int64_t *)field = k;
    return EJ_OK;
  }
  case EJ_PT_BOOL: {
    bool b = false;
    if (v->type != EJ_NODE_SCALAR || v->quoted || !ej_parse_bool(v->text, &b)) return ej_wrong_type(p, v, what);
    *(bool *)field = b;
    return EJ_OK;
  }
  case EJ_PT_ENUM: {
    if (v->type != EJ_NODE_SCALAR) return ej_wrong_type(p, v, what);
    int k = ej_enum_index(p->choices, v->text);
    if (k >= 0) {
      *(int *)field = k;
      return EJ_OK;
    }
    char list[256];
    int n = ej_choice_count(p->choices);
    ej_join(list, sizeof list, p->choices, n, ", ");
    const char *near = ej_nearest_word(v->text, p->choices, n);
    if (near)
      return ej_error_input(&v->loc, "%s must be one of %s, got '%s'; did you mean '%s'?", subject, list, v->text,
                            near);
    return ej_error_input(&v->loc, "%s must be one of %s, got '%s'", subject, list, v->text);
  }
  case EJ_PT_STRING:
    if (v->type != EJ_NODE_SCALAR) return ej_wrong_type(p, v, what);
    if (p->flags & EJ_PF_PATH) EJ_TRY(ej_param_path((ej_node *)v, subject));
    *(const char **)field = v->text;
    return EJ_OK;
  case EJ_PT_REAL_ARRAY: {
    if (v->type != EJ_NODE_SEQ) return ej_wrong_type(p, v, what);
    if (v->n != p->count)
      return ej_error_input(&v->loc, "%s must be a list of %d numbers, got %d", subject, p->count, v->n);
    for (int i = 0; i < v->n; ++i) {
      char item[EJ_WHAT_LEN + 64];
      snprintf(item, sizeof item, "'%s[%d]' in %s", p->name, i, what);
      EJ_TRY(ej_param_real(p, v->items[i], what, item, (ej_real *)field + i));
    }
    return EJ_OK;
  }
  case EJ_PT_BLOCK: {
    if (v->type != EJ_NODE_MAP) return ej_wrong_type(p, v, what);
    char sub[EJ_WHAT_LEN];
    snprintf(sub, sizeof sub, "%s.%s", what, p->name);
    EJ_TRY(ej_params_apply(p->sub, field, v, sub, NULL, NULL));
    return EJ_OK;
  }
  }
  EJ_FAIL(EJ_ERR_PLUGIN, "parameter '%s' has unknown type %d", p->name, (int)p->type);
}

static ej_err ej_unknown_key(const ej_param *table, const char *const *skip, const char *key, const ej_loc *loc,
                             const char *what)
{
  int nt = ej_param_count(table), ns = 0;
  while (skip && skip[ns]) ++ns;
  const char **names = ej_calloc((size_t)(nt + ns + 1), sizeof *names);
  EJ_ENSURE(names, EJ_ERR_MEM, "out of memory");
  for (int i = 0; i < nt; ++i) names[i] = table[i].name;
  for (int i = 0; i < ns; ++i) names[nt + i] = skip[i];
  const char *near = ej_nearest_word(key, names, nt + ns);
  ej_err rc;
  if (near) {
    rc = ej_error_input(loc, "unknown key '%s' in %s; did you mean '%s'?", key, what, near);
  } else {
    char list[400];
    ej_join(list, sizeof list, names, nt + ns, ", ");
    rc = ej_error_input(loc, "unknown key '%s' in %s (valid keys: %s)", key, what, list);
  }
  ej_free(names);
  return rc;
}

static bool ej_in_list(const char *const *list, const char *word)
{
  for (int i = 0; list && list[i]; ++i)
    if (strcmp(list[i], word) == 0) return true;
  return false;
}

ej_err ej_params_apply(const ej_param *table, void *config, const ej_node *map, const char *what,
                       const char *const *skip, ej_config_check_fn check)
{
  EJ_ENSURE(what, EJ_ERR_ARG, "NULL what");
  EJ_TRY(ej_params_defaults(table, config));
  if (map && map->type != EJ_NODE_MAP) {
    char gb[128];
    return ej_error_input(&map->loc, "%s must be a mapping, got %s", what, ej_node_what(map, gb, sizeof gb));
  }
  for (int i = 0; map && i < map->n; ++i) {
    const char *key = map->keys[i];
    if (ej_in_list(skip, key)) continue;
    const ej_param *p = ej_param_find(table, key);
    if (!p) return ej_unknown_key(table, skip, key, &map->key_locs[i], what);
    EJ_TRY(ej_param_value(p, config, map->items[i], what));
  }
  for (const ej_param *p = table; p && p->name; ++p) {
    if (!(p->flags & EJ_PF_REQUIRED) || ej_node_get(map, p->name)) continue;
    const ej_loc *loc = map ? &map->loc : NULL;
    if (p->doc) return ej_error_input(loc, "%s is missing required key '%s' (%s)", what, p->name, p->doc);
    return ej_error_input(loc, "%s is missing required key '%s'", what, p->name);
  }
  if (check) {
    ej_diag d = {.block = map, .what = what};
    EJ_TRY(check(config, &d));
  }
  return EJ_OK;
}

ej_err ej_diag_error(ej_diag *d, const char *key, const char *fmt, ...)
{
  char msg[EJ_ERROR_MSG_LEN];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  if (!d) return ej_error_input(NULL, "%s", msg);
  const ej_loc *loc = key ? ej_node_key_loc(d->block, key) : NULL;
  if (!loc && d->block) loc = &d->block->loc;
  return ej_error_input(loc, "%s: %s", d->what ? d->what : "input", msg);
}

/* ------------------------------------------------------------------ describe */

typedef struct ej_describe_row {
  char type[160], def[64], range[96];
} ej_describe_row;

static void ej_describe_fill(const ej_param *p, ej_describe_row *r)
{
  const char *unit = ej_param_unit(p);
  bool plain = ej_unit_is_plain(unit);
  r->range[0] = '\0';
  snprintf(r->def, sizeof r->def, "-");
  switch (p->type) {
  case EJ_PT_REAL:
    snprintf(r->type, sizeof r->type, "number%s%s%s", plain ? "" : " [", plain ? "" : unit, plain ? "" : "]");
    snprintf(r->def, sizeof r->def, "%g", p->def);
    break;
  case EJ_PT_INT:
    snprintf(r->type, sizeof r->type, "integer");
    snprintf(r->def, sizeof r->def, "%lld", (long long)p->def);
    break;
  case EJ_PT_BOOL:
    snprintf(r->type, sizeof r->type, "true|false");
    snprintf(r->def, sizeof r->def, "%s", p->def != 0 ? "true" : "false");
    break;
  case EJ_PT_ENUM: {
    char list[140];
    ej_join(list, sizeof list, p->choices, ej_choice_count(p->choices), "|");
    snprintf(r->type, sizeof r->type, "one of %s", list);
    snprintf(r->def, sizeof r->def, "%s", p->def_str ? p->def_str : (p->choices && p->choices[0] ? p->choices[0] : "-"));
    break;
  }
  case EJ_PT_STRING:
    snprintf(r->type, sizeof r->type, (p->flags & EJ_PF_PATH) ? "file" : "text");
    if (p->def_str) snprintf(r->def, sizeof r->def, "\"%s\"", p->def_str);
    break;
  case EJ_PT_REAL_ARRAY:
    snprintf(r->type, sizeof r->type, "[%d numbers]%s%s%s", p->count, plain ? "" : " [", plain ? "" : unit,
             plain ? "" : "]");
    snprintf(r->def, sizeof r->def, "zeros");
    break;
  case EJ_PT_BLOCK:
    snprintf(r->type, sizeof r->type, "block");
    r->def[0] = '\0';
    break;
  }
  if (p->flags & EJ_PF_REQUIRED) snprintf(r->def, sizeof r->def, "required");
  if ((p->type == EJ_PT_REAL || p->type == EJ_PT_INT || p->type == EJ_PT_REAL_ARRAY) &&
      (p->flags & (EJ_PF_HAS_MIN | EJ_PF_HAS_MAX)))
    ej_param_range(p, r->range, sizeof r->range);
}

ej_err ej_params_describe(ej_buf *out, const ej_param *table, int indent)
{
  EJ_ENSURE(out, EJ_ERR_ARG, "NULL buffer");
  int n = ej_param_count(table);
  if (n == 0) return ej_buf_printf(out, "%*s(no parameters)\n", indent, "");
  ej_describe_row *rows = ej_calloc((size_t)n, sizeof *rows);
  EJ_ENSURE(rows, EJ_ERR_MEM, "out of memory");
  int wn = 0, wt = 0, wd = 0, wr = 0;
  for (int i = 0; i < n; ++i) {
    ej_describe_fill(&table[i], &rows[i]);
    int l = (int)strlen(table[i].name);
    wn = l > wn ? l : wn;
    l = (int)strlen(rows[i].type);
    wt = l > wt ? l : wt;
    l = (int)strlen(rows[i].def);
    wd = l > wd ? l : wd;
    l = (int)strlen(rows[i].range);
    wr = l > wr ? l : wr;
  }
  ej_err rc = EJ_OK;
  for (int i = 0; i < n && rc == EJ_OK; ++i) {
    const ej_param *p = &table[i];
    rc = ej_buf_printf(out, "%*s%-*s  %-*s  %-*s  %-*s  %s%s\n", indent, "", wn, p->name, wt, rows[i].type, wd,
                       rows[i].def, wr, rows[i].range, (p->flags & EJ_PF_EXPERT) ? "(expert) " : "",
                       p->doc ? p->doc : "");
    if (rc == EJ_OK && p->type == EJ_PT_BLOCK) rc = ej_params_describe(out, p->sub, indent + 4);
  }
  ej_free(rows);
  EJ_TRY(rc);
  return EJ_OK;
}

/* Text for a Markdown table cell: '|' escaped, newlines as spaces. */
static ej_err ej_md_cell(ej_buf *out, const char *s)
{
  if (!s || !*s) return ej_buf_printf(out, " - |");
  EJ_TRY(ej_buf_printf(out, " "));
  for (const char *c = s; *c; ++c) {
    if (*c == '|') EJ_TRY(ej_buf_printf(out, "\\|"));
    else if (*c == '\n') EJ_TRY(ej_buf_printf(out, " "));
    else EJ_TRY(ej_buf_printf(out, "%c", *c));
  }
  return ej_buf_printf(out, " |");
}

static ej_err ej_md_rows(ej_buf *out, const ej_param *table, const char *prefix)
{
  for (const ej_param *p = table; p && p->name; ++p) {
    ej_describe_row r;
    ej_describe_fill(p, &r);
    const char *unit = ej_param_unit(p);
    static const char *const types[] = {"number", "integer", "bool", "enum", "text", "numbers", "block"};
    char type[32], name[160], choices[160] = "";
    snprintf(type, sizeof type, "%s", p->type <= EJ_PT_BLOCK ? types[p->type] : "?");
    if (p->type == EJ_PT_REAL_ARRAY) snprintf(type, sizeof type, "number[%d]", p->count);
    if (p->type == EJ_PT_STRING && (p->flags & EJ_PF_PATH)) snprintf(type, sizeof type, "file");
    snprintf(name, sizeof name, "`%s%s`", prefix, p->name);
    if (p->type == EJ_PT_ENUM) ej_join(choices, sizeof choices, p->choices, ej_choice_count(p->choices), ", ");
    EJ_TRY(ej_buf_printf(out, "|"));
    EJ_TRY(ej_md_cell(out, name));
    EJ_TRY(ej_md_cell(out, type));
    EJ_TRY(ej_md_cell(out, p->type == EJ_PT_REAL || p->type == EJ_PT_REAL_ARRAY ? (ej_unit_is_plain(unit) ? "1" : unit)
                                                                                 : ""));
    EJ_TRY(ej_md_cell(out, r.def));
    EJ_TRY(ej_md_cell(out, r.range));
    EJ_TRY(ej_md_cell(out, choices));
    char doc[1024];
    snprintf(doc, sizeof doc, "%s%s", (p->flags & EJ_PF_EXPERT) ? "(expert) " : "", p->doc ? p->doc : "");
    EJ_TRY(ej_md_cell(out, doc));
    EJ_TRY(ej_buf_printf(out, "\n"));
    if (p->type == EJ_PT_BLOCK) {
      char sub[160];
      snprintf(sub, sizeof sub, "%s%s.", prefix, p->name);
      EJ_TRY(ej_md_rows(out, p->sub, sub));
    }
  }
  return EJ_OK;
}

ej_err ej_params_markdown(ej_buf *out, const ej_param *table)
{
  EJ_ENSURE(out, EJ_ERR_ARG, "NULL buffer");
  if (ej_param_count(table) == 0) return ej_buf_printf(out, "No parameters.\n");
  EJ_TRY(ej_buf_printf(out, "| name | type | unit | default | bounds | choices | description |\n"
                            "|---|---|---|---|---|---|---|\n"));
  return ej_md_rows(out, table, "");
}

/* ------------------------------------------------------------------ JSON Schema */

static ej_err ej_json_str(ej_buf *b, const char *s)
{
  EJ_TRY(ej_buf_printf(b, "\""));
  for (const unsigned char *c = (const unsigned char *)(s ? s : ""); *c; ++c) {
    switch (*c) {
    case '"': EJ_TRY(ej_buf_printf(b, "\\\"")); break;
    case '\\': EJ_TRY(ej_buf_printf(b, "\\\\")); break;
    case '\n': EJ_TRY(ej_buf_printf(b, "\\n")); break;
    case '\t': EJ_TRY(ej_buf_printf(b, "\\t")); break;
    case '\r': EJ_TRY(ej_buf_printf(b, "\\r")); break;
    default:
      if (*c < 0x20) EJ_TRY(ej_buf_printf(b, "\\u%04x", *c));
      else EJ_TRY(ej_buf_printf(b, "%c", *c));
    }
  }
  EJ_TRY(ej_buf_printf(b, "\""));
  return EJ_OK;
}

/* Shortest decimal that reads back to the same double: stable, diff-friendly schema files. */
static ej_err ej_json_num(ej_buf *b, double v)
{
  char s[40];
  if (v == floor(v) && fabs(v) < 1e15) {
    EJ_TRY(ej_buf_printf(b, "%.0f", v == 0 ? 0.0 : v)); /* no "-0", no "9e+01" */
    return EJ_OK;
  }
  for (int prec = 1; prec <= 17; ++prec) {
    snprintf(s, sizeof s, "%.*g", prec, v);
    if (strtod(s, NULL) == v) break;
  }
  EJ_TRY(ej_buf_printf(b, "%s", s));
  return EJ_OK;
}

/* "minimum"/"exclusiveMinimum"/... in the declared unit. */
static ej_err ej_json_bounds(ej_buf *b, const ej_param *p)
{
  if ((p->flags & EJ_PF_HAS_MIN) && isfinite(p->min)) {
    EJ_TRY(ej_buf_printf(b, ",\"%s\":", (p->flags & EJ_PF_MIN_OPEN) ? "exclusiveMinimum" : "minimum"));
    EJ_TRY(ej_json_num(b, p->min));
  }
  if ((p->flags & EJ_PF_HAS_MAX) && isfinite(p->max)) {
    EJ_TRY(ej_buf_printf(b, ",\"%s\":", (p->flags & EJ_PF_MAX_OPEN) ? "exclusiveMaximum" : "maximum"));
    EJ_TRY(ej_json_num(b, p->max));
  }
  return EJ_OK;
}

/* A number that may carry a unit: either a JSON number (in the declared unit, bounds apply)
 * or a string "VALUE UNIT" that the loader converts. */
static ej_err ej_json_number(ej_buf *b, const ej_param *p, bool with_default)
{
  const char *unit = ej_param_unit(p);
  if (ej_unit_is_plain(unit)) {
    EJ_TRY(ej_buf_printf(b, "{\"type\":\"number\""));
    EJ_TRY(ej_json_bounds(b, p));
  } else {
    EJ_TRY(ej_buf_printf(b, "{\"oneOf\":[{\"type\":\"number\""));
    EJ_TRY(ej_json_bounds(b, p));
    EJ_TRY(ej_buf_printf(b, "},{\"type\":\"string\",\"pattern\":\"^\\\\s*[-+0-9.eE]+\\\\s*\\\\S*$\"}]"));
    EJ_TRY(ej_buf_printf(b, ",\"x-unit\":"));
    EJ_TRY(ej_json_str(b, unit));
  }
  if (with_default && !(p->flags & EJ_PF_REQUIRED) && isfinite(p->def)) {
    EJ_TRY(ej_buf_printf(b, ",\"default\":"));
    EJ_TRY(ej_json_num(b, p->def));
  }
  return EJ_OK;
}

static ej_err ej_json_param(ej_buf *b, const ej_param *p)
{
  bool req = (p->flags & EJ_PF_REQUIRED) != 0;
  switch (p->type) {
  case EJ_PT_REAL: EJ_TRY(ej_json_number(b, p, true)); break;
  case EJ_PT_INT:
    EJ_TRY(ej_buf_printf(b, "{\"type\":\"integer\""));
    EJ_TRY(ej_json_bounds(b, p));
    if (!req) EJ_TRY(ej_buf_printf(b, ",\"default\":%lld", (long long)p->def));
    break;
  case EJ_PT_BOOL:
    EJ_TRY(ej_buf_printf(b, "{\"type\":\"boolean\""));
    if (!req) EJ_TRY(ej_buf_printf(b, ",\"default\":%s", p->def != 0 ? "true" : "false"));
    break;
  case EJ_PT_ENUM:
    EJ_TRY(ej_buf_printf(b, "{\"enum\":["));
    for (int i = 0; p->choices && p->choices[i]; ++i) {
      if (i) EJ_TRY(ej_buf_printf(b, ","));
      EJ_TRY(ej_json_str(b, p->choices[i]));
    }
    EJ_TRY(ej_buf_printf(b, "]"));
    if (!req && (p->def_str || (p->choices && p->choices[0]))) {
      EJ_TRY(ej_buf_printf(b, ",\"default\":"));
      EJ_TRY(ej_json_str(b, p->def_str ? p->def_str : p->choices[0]));
    }
    break;
  case EJ_PT_STRING:
    EJ_TRY(ej_buf_printf(b, "{\"type\":\"string\""));
    if (!req && p->def_str) {
      EJ_TRY(ej_buf_printf(b, ",\"default\":"));
      EJ_TRY(ej_json_str(b, p->def_str));
    }
    break;
  case EJ_PT_REAL_ARRAY:
    EJ_TRY(ej_buf_printf(b, "{\"type\":\"array\",\"minItems\":%d,\"maxItems\":%d,\"items\":", p->count, p->count));
    EJ_TRY(ej_json_number(b, p, false));
    EJ_TRY(ej_buf_printf(b, "}"));
    break;
  case EJ_PT_BLOCK:
    /* The block's object schema stays open so that the description can be appended. */
    EJ_TRY(ej_params_schema(b, p->sub, NULL));
    EJ_ENSURE(b->len && b->data[b->len - 1] == '}', EJ_ERR_INTERNAL, "schema not an object");
    b->data[--b->len] = '\0';
    break;
  default: EJ_FAIL(EJ_ERR_PLUGIN, "parameter '%s' has unknown type %d", p->name, (int)p->type);
  }
  if (p->doc) {
    EJ_TRY(ej_buf_printf(b, ",\"description\":"));
    EJ_TRY(ej_json_str(b, p->doc));
  }
  EJ_TRY(ej_buf_printf(b, "}"));
  return EJ_OK;
}

ej_err ej_params_schema(ej_buf *out, const ej_param *table, const char *const *extra_keys)
{
  EJ_ENSURE(out, EJ_ERR_ARG, "NULL buffer");
  EJ_TRY(ej_buf_printf(out, "{\"type\":\"object\",\"additionalProperties\":false,\"properties\":{"));
  bool first = true;
  for (const ej_param *p = table; p && p->name; ++p) {
    if (!first) EJ_TRY(ej_buf_printf(out, ","));
    first = false;
    EJ_TRY(ej_json_str(out, p->name));
    EJ_TRY(ej_buf_printf(out, ":"));
    EJ_TRY(ej_json_param(out, p));
  }
  for (int i = 0; extra_keys && extra_keys[i]; ++i) {
    if (ej_param_find(table, extra_keys[i])) continue;
    if (!first) EJ_TRY(ej_buf_printf(out, ","));
    first = false;
    EJ_TRY(ej_json_str(out, extra_keys[i]));
    EJ_TRY(ej_buf_printf(out, ":{}"));
  }
  EJ_TRY(ej_buf_printf(out, "}"));
  bool any = false;
  for (const ej_param *p = table; p && p->name; ++p) {
    if (!(p->flags & EJ_PF_REQUIRED)) continue;
    EJ_TRY(ej_buf_printf(out, any ? "," : ",\"required\":["));
    any = true;
    EJ_TRY(ej_json_str(out, p->name));
  }
  if (any) EJ_TRY(ej_buf_printf(out, "]"));
  EJ_TRY(ej_buf_printf(out, "}"));
  return EJ_OK;
}
