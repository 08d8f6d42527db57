/* Numbers with units ("4 mm", "8.7 GPa", "1.6 g/cm^3", "30 deg") converted to SI against
 * the unit a parameter table declares. A dimension is a vector of integer exponents of
 * length, mass, time, temperature and angle; angle is kept apart from dimensionless so that
 * "30" for an angle means degrees while "0.3" for a ratio stays 0.3. */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "units_impl.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { EJ_DIM_L, EJ_DIM_M, EJ_DIM_T, EJ_DIM_K, EJ_DIM_A, EJ_NDIM };

typedef struct ej_unit_def {
  const char *name;
  double scale;
  signed char e[EJ_NDIM];
} ej_unit_def;

/* A value quoted in a message: at most 60 characters of a longer one, then "..." (the message keeps
 * its place for the rest: what was expected). Expands to the three arguments of '%.*s%s'. */
#define EJ_SHOWN(len, p) (int)((len) > 64 ? 60 : (len)), (p), ((len) > 64 ? "..." : "")

static const ej_unit_def ej_unit_defs[] = {
    {"m", 1, {1, 0, 0, 0, 0}},        {"cm", 1e-2, {1, 0, 0, 0, 0}},   {"mm", 1e-3, {1, 0, 0, 0, 0}},
    {"um", 1e-6, {1, 0, 0, 0, 0}},    {"km", 1e3, {1, 0, 0, 0, 0}},    {"s", 1, {0, 0, 1, 0, 0}},
    {"ms", 1e-3, {0, 0, 1, 0, 0}},    {"us", 1e-6, {0, 0, 1, 0, 0}},   {"ns", 1e-9, {0, 0, 1, 0, 0}},
    {"kg", 1, {0, 1, 0, 0, 0}},       {"g", 1e-3, {0, 1, 0, 0, 0}},    {"mg", 1e-6, {0, 1, 0, 0, 0}},
    {"Pa", 1, {-1, 1, -2, 0, 0}},     {"kPa", 1e3, {-1, 1, -2, 0, 0}}, {"MPa", 1e6, {-1, 1, -2, 0, 0}},
    {"GPa", 1e9, {-1, 1, -2, 0, 0}},  {"bar", 1e5, {-1, 1, -2, 0, 0}}, {"N", 1, {1, 1, -2, 0, 0}},
    {"J", 1, {2, 1, -2, 0, 0}},       {"kJ", 1e3, {2, 1, -2, 0, 0}},   {"MJ", 1e6, {2, 1, -2, 0, 0}},
    {"GJ", 1e9, {2, 1, -2, 0, 0}},    {"W", 1, {2, 1, -3, 0, 0}},      {"K", 1, {0, 0, 0, 1, 0}},
    {"deg", M_PI / 180, {0, 0, 0, 0, 1}}, {"rad", 1, {0, 0, 0, 0, 1}}, {"1", 1, {0, 0, 0, 0, 0}},
};
#define EJ_N_UNITS ((int)(sizeof ej_unit_defs / sizeof ej_unit_defs[0]))

/* A parsed unit expression. energy records that a joule appeared, to tell an energy density
 * (J/m^3) from a pressure (Pa) in messages: the two share a dimension. */
typedef struct ej_unit {
  double scale;
  int e[EJ_NDIM];
  bool energy;
} ej_unit;

typedef enum ej_unit_status { EJ_UNIT_OK, EJ_UNIT_UNKNOWN, EJ_UNIT_SYNTAX } ej_unit_status;

/* Parses "kg/m^3", "J/kg", "kg*m/s^2", "m^-3" left to right (a/b/c = a/(b c)). On failure
 * bad receives the unknown name or the rest of the text at the syntax error. */
static ej_unit_status ej_unit_expr(const char *s, ej_unit *u, char *bad, size_t bad_size)
{
  *u = (ej_unit){.scale = 1};
  int sign = 1;
  const char *p = s;
  for (;;) {
    while (*p == ' ' || *p == '\t') ++p;
    const char *start = p;
    while (isalpha((unsigned char)*p) || *p == '_') ++p;
    if (p == start && *p == '1') ++p;
    if (p == start) {
      snprintf(bad, bad_size, "%s", start);
      return EJ_UNIT_SYNTAX;
    }
    size_t len = (size_t)(p - start);
    const ej_unit_def *def = NULL;
    for (int i = 0; i < EJ_N_UNITS; ++i)
      if (strlen(ej_unit_defs[i].name) == len && strncmp(ej_unit_defs[i].name, start, len) == 0)
        def = &ej_unit_defs[i];
    if (!def) {
      snprintf(bad, bad_size, "%.*s", (int)len, start);
      return EJ_UNIT_UNKNOWN;
    }
    while (*p == ' ' || *p == '\t') ++p;
    int power = 1;
    if (*p == '^') {
      ++p;
      int psign = 1;
      if (*p == '-' || *p == '+') psign = *p++ == '-' ? -1 : 1;
      /* One digit is plenty for physical units and keeps pow() far from overflow. */
      if (!isdigit((unsigned char)*p) || isdigit((unsigned char)p[1])) {
        snprintf(bad, bad_size, "%s", start);
        return EJ_UNIT_SYNTAX;
      }
      power = psign * (*p++ - '0');
      while (*p == ' ' || *p == '\t') ++p;
    }
    int k = sign * power;
    u->scale *= pow(def->scale, k);
    for (int d = 0; d < EJ_NDIM; ++d) u->e[d] += k * def->e[d];
    if (strchr(def->name, 'J')) u->energy = true;
    if (*p == '\0') return EJ_UNIT_OK;
    if (*p == '*') sign = 1;
    else if (*p == '/') sign = -1;
    else {
      snprintf(bad, bad_size, "%s", p);
      return EJ_UNIT_SYNTAX;
    }
    ++p;
  }
}

static bool ej_unit_same_dim(const ej_unit *a, const ej_unit *b)
{
  for (int d = 0; d < EJ_NDIM; ++d)
    if (a->e[d] != b->e[d]) return false;
  return true;
}

/* "a length", "an energy density", ... or a generic description for rare dimensions. */
static const char *ej_unit_dim_name(const ej_unit *u, char *buf, size_t size)
{
  static const struct {
    signed char e[EJ_NDIM];
    const char *name;
  } names[] = {
      {{0, 0, 0, 0, 0}, "dimensionless"},   {{1, 0, 0, 0, 0}, "a length"},
      {{0, 0, 1, 0, 0}, "a time"},          {{0, 1, 0, 0, 0}, "a mass"},
      {{-1, 1, -2, 0, 0}, "a pressure"},    {{-3, 1, 0, 0, 0}, "a density"},
      {{2, 1, -2, 0, 0}, "an energy"},      {{2, 0, -2, 0, 0}, "a specific energy"},
      {{1, 0, -1, 0, 0}, "a velocity"},     {{1, 0, -2, 0, 0}, "an acceleration"},
      {{1, 1, -2, 0, 0}, "a force"},        {{2, 1, -3, 0, 0}, "a power"},
      {{0, 0, 0, 1, 0}, "a temperature"},   {{0, 0, 0, 0, 1}, "an angle"},
      {{2, 0, 0, 0, 0}, "an area"},         {{3, 0, 0, 0, 0}, "a volume"},
      {{0, 0, -1, 0, 0}, "a rate (1/s)"},   {{2, 0, -2, -1, 0}, "a specific heat"},
  };
  for (size_t i = 0; i < sizeof names / sizeof names[0]; ++i) {
    bool same = true;
    for (int d = 0; d < EJ_NDIM; ++d) same = same && names[i].e[d] == u->e[d];
    if (!same) continue;
    if (u->energy && u->e[EJ_DIM_L] == -1 && u->e[EJ_DIM_M] == 1) return "an energy density";
    return names[i].name;
  }
  static const char *base[EJ_NDIM] = {"m", "kg", "s", "K", "rad"};
  size_t len = (size_t)snprintf(buf, size, "a quantity in");
  for (int d = 0; d < EJ_NDIM && len < size; ++d)
    if (u->e[d]) len += (size_t)snprintf(buf + len, size - len, u->e[d] == 1 ? " %s" : " %s^%d", base[d], u->e[d]);
  return buf;
}

/* Scans an optional sign, digits, a fraction and an exponent; returns the length, 0 if none.
 * strtod alone would also take "nan", "inf" and hex floats, which are no scene numbers. */
static size_t ej_number_span(const char *s)
{
  size_t i = 0, digits = 0;
  if (s[i] == '+' || s[i] == '-') ++i;
  while (isdigit((unsigned char)s[i])) ++i, ++digits;
  if (s[i] == '.') {
    ++i;
    while (isdigit((unsigned char)s[i])) ++i, ++digits;
  }
  if (!digits) return 0;
  if (s[i] == 'e' || s[i] == 'E') {
    size_t j = i + 1;
    if (s[j] == '+' || s[j] == '-') ++j;
    if (isdigit((unsigned char)s[j])) {
      while (isdigit((unsigned char)s[j])) ++j;
      i = j;
    }
  }
  return i;
}

/* A digit in a unit text that is not part of a power ("m^-3") or the unit "1". */
static bool ej_stray_digit(const char *u)
{
  for (const char *c = u; *c; ++c) {
    if (!isdigit((unsigned char)*c)) continue;
    const char *q = c;
    while (q > u && (isdigit((unsigned char)q[-1]) || q[-1] == '-' || q[-1] == '+')) --q;
    if (q > u && q[-1] == '^') continue;
    if (*q == '1' && !isdigit((unsigned char)q[1]) && (q == u || q[-1] == '/' || q[-1] == '*' || q[-1] == ' '))
      continue;
    return true;
  }
  return false;
}

static void ej_unit_list(char *buf, size_t size)
{
  size_t len = 0;
  buf[0] = '\0';
  for (int i = 0; i < EJ_N_UNITS && len < size; ++i)
    len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? ", " : "", ej_unit_defs[i].name);
}

/* Input error at loc, prefixed "<subject>: " when there is a subject. */
static ej_err ej_units_error(const ej_loc *loc, const char *subject, const char *msg)
{
  if (subject) return ej_error_input(loc, "%s: %s", subject, msg);
  return ej_error_input(loc, "%s", msg);
}

ej_err ej_units_parse_as(const char *text, const char *declared_unit, const ej_loc *loc, const char *subject,
                         double *si)
{
  EJ_ENSURE(text && declared_unit && si, EJ_ERR_ARG, "NULL argument");
  char msg[EJ_ERROR_MSG_LEN], bad[128];
  ej_unit want, got;
  if (ej_unit_expr(declared_unit, &want, bad, sizeof bad) != EJ_UNIT_OK)
    EJ_FAIL(EJ_ERR_ARG, "parameter table declares unit '%s', which does not parse", declared_unit);

  const char *p = text;
  while (isspace((unsigned char)*p)) ++p;
  size_t nlen = ej_number_span(p);
  /* Trailing blanks are not part of the unit; text is not ours to modify. */
  size_t tlen = strlen(p);
  while (tlen && isspace((unsigned char)p[tlen - 1])) --tlen;
  if (nlen == 0) {
    snprintf(msg, sizeof msg, "expected a number, got '%.*s%s'", EJ_SHOWN(tlen, p));
    return ej_units_error(loc, subject, msg);
  }
  char num[64];
  if (nlen >= sizeof num) {
    snprintf(msg, sizeof msg, "number '%.*s%s' is too long", EJ_SHOWN(tlen, p));
    return ej_units_error(loc, subject, msg);
  }
  memcpy(num, p, nlen);
  num[nlen] = '\0';
  double value = strtod(num, NULL);

  const char *u = p + nlen;
  while (u < p + tlen && isspace((unsigned char)*u)) ++u;
  size_t ulen = tlen - (size_t)(u - p);
  if (ulen == 0) {
    got = want; /* a plain number is in the declared unit */
  } else {
    char ubuf[128];
    if (ulen >= sizeof ubuf) {
      snprintf(msg, sizeof msg, "unit in '%.*s%s' is too long", EJ_SHOWN(tlen, p));
      return ej_units_error(loc, subject, msg);
    }
    memcpy(ubuf, u, ulen);
    ubuf[ulen] = '\0';
    /* "1,000" or "3..4" are bad numbers, not bad units. */
    if (!isalpha((unsigned char)ubuf[0]) && ubuf[0] != '1') {
      snprintf(msg, sizeof msg, "expected a number, got '%.*s%s'", EJ_SHOWN(tlen, p));
      return ej_units_error(loc, subject, msg);
    }
    ej_unit_status st = ej_unit_expr(ubuf, &got, bad, sizeof bad);
    /* "0x10" or "1d5" glued to the number are number typos, not unknown units. */
    if (st != EJ_UNIT_OK && u == p + nlen && ej_stray_digit(ubuf)) {
      snprintf(msg, sizeof msg, "expected a number, got '%.*s%s'", EJ_SHOWN(tlen, p));
      return ej_units_error(loc, subject, msg);
    }
    if (st == EJ_UNIT_UNKNOWN) {
      const char *names[EJ_N_UNITS];
      for (int i = 0; i < EJ_N_UNITS; ++i) names[i] = ej_unit_defs[i].name;
      const char *near = ej_nearest_word(bad, names, EJ_N_UNITS);
      if (near) {
        snprintf(msg, sizeof msg, "unknown unit '%s' in '%.*s%s'; did you mean '%s'?", bad, EJ_SHOWN(tlen, p), near);
      } else {
        char list[256];
        ej_unit_list(list, sizeof list);
        snprintf(msg, sizeof msg, "unknown unit '%s' in '%.*s%s' (known units: %s)", bad, EJ_SHOWN(tlen, p), list);
      }
      return ej_units_error(loc, subject, msg);
    }
    if (st == EJ_UNIT_SYNTAX) {
      snprintf(msg, sizeof msg,
               "malformed unit '%s' in '%.*s%s' (write units like 'GPa', 'g/cm^3' or 'm/s^2')", ubuf,
               EJ_SHOWN(tlen, p));
      return ej_units_error(loc, subject, msg);
    }
  }

  if (!ej_unit_same_dim(&want, &got)) {
    char wb[96], gb[96];
    const char *wn = ej_unit_dim_name(&want, wb, sizeof wb);
    const char *gn = ej_unit_dim_name(&got, gb, sizeof gb);
    bool plain = strcmp(wn, "dimensionless") == 0;
    int n = snprintf(msg, sizeof msg, "%s%s", subject ? subject : "", subject ? " " : "");
    if (plain)
      snprintf(msg + n, sizeof msg - (size_t)n, "expects a plain number without unit, got '%.*s%s' (%s)",
               EJ_SHOWN(tlen, p), gn);
    else
      snprintf(msg + n, sizeof msg - (size_t)n, "expects %s (%s), got '%.*s%s' (%s)", wn, declared_unit,
               EJ_SHOWN(tlen, p), gn);
    return ej_error_input(loc, "%s", msg);
  }

  double v = value * got.scale;
  if (!isfinite(v)) {
    snprintf(msg, sizeof msg, "'%.*s%s' is out of the range of double precision numbers", EJ_SHOWN(tlen, p));
    return ej_units_error(loc, subject, msg);
  }
  *si = v;
  return EJ_OK;
}

ej_err ej_units_parse(const char *text, const char *declared_unit, const ej_loc *loc, double *si)
{
  return ej_units_parse_as(text, declared_unit, loc, NULL, si);
}

bool ej_units_compatible(const char *a, const char *b)
{
  ej_unit ua, ub;
  char bad[64];
  if (!a || !b) return false;
  if (ej_unit_expr(a, &ua, bad, sizeof bad) != EJ_UNIT_OK) return false;
  if (ej_unit_expr(b, &ub, bad, sizeof bad) != EJ_UNIT_OK) return false;
  return ej_unit_same_dim(&ua, &ub);
}

bool ej_units_scale(const char *unit, double *scale)
{
  ej_unit u;
  char bad[64];
  if (!unit || ej_unit_expr(unit, &u, bad, sizeof bad) != EJ_UNIT_OK) return false;
  *scale = u.scale;
  return true;
}
