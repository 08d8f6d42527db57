/* The ejecta command line: run | check | plugins | describe NAME | schema.
 * Exit codes: 0 success, 1 a run that failed (watchdog, numerics, I/O), 2 bad input, 128 + N a run
 * stopped by signal N (SIGINT 130, SIGTERM 143) with its state kept for --restart. */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"

/* Particles of a face boundary's region (non_reflecting, pressure) lying under another one of it: q
 * between 0.5 and 1.5 spacings outward of p along p's normal and within half a spacing of that line.
 * A one-layer face has none; a thicker region would load (or damp) every layer. -1: not checked
 * (regions over 20,000 particles: the test is quadratic). */
static long ej_face_covered(const ej_scene *sc, const ej_set *s, int b)
{
  const ej_scene_bc *bc = &sc->bcs[b];
  const ej_real *x = ej_set_field(s, "x"), *vol0 = ej_set_field(s, "vol0");
  ej_idx n = 0;
  for (ej_idx p = 0; p < s->n; ++p) n += (s->bc_mask[p] >> b) & 1u;
  if (n > 20000) return -1;
  ej_idx *in = malloc((size_t)(n > 0 ? n : 1) * sizeof *in);
  if (!in) return -1;
  n = 0;
  for (ej_idx p = 0; p < s->n; ++p)
    if ((s->bc_mask[p] >> b) & 1u) in[n++] = p;
  long covered = 0;
  for (ej_idx a = 0; a < n; ++a) {
    const ej_real *xp = x + 3 * in[a];
    const ej_real h = sc->dimension == 3 ? cbrt(vol0[in[a]]) : sc->dimension == 2 ? sqrt(vol0[in[a]]) : vol0[in[a]];
    ej_real nv[3];
    if (!ej_bc_face_normal(bc, xp, nv)) continue;
    for (ej_idx c = 0; c < n; ++c) {
      const ej_real *xq = x + 3 * in[c];
      const ej_real d[3] = {xq[0] - xp[0], xq[1] - xp[1], xq[2] - xp[2]};
      const ej_real along = d[0] * nv[0] + d[1] * nv[1] + d[2] * nv[2];
      if (!(along > 0.5 * h && along < 1.5 * h)) continue;
      const ej_real l2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - along * along;
      if (l2 < 0.25 * h * h) {
        ++covered;
        break;
      }
    }
  }
  free(in);
  return covered;
}

/* The warning line of ej_face_covered, if any: over a tenth of the region covered (a staircase of a
 * lattice along a curved or inclined face puts a few particles behind their neighbours; a doubled
 * layer covers about half of them). */
static void ej_face_warn(const ej_scene *sc, const ej_set *s, int b, const char *what)
{
  const long k = ej_face_covered(sc, s, b);
  long n = 0;
  for (ej_idx p = 0; p < s->n; ++p) n += (s->bc_mask[p] >> b) & 1u;
  if (k > 0 && 10 * k > n)
    printf("warning: %s (line %d) on set '%s': %ld particles of its region lie under another one of it along the "
           "face's normal: the region is more than one particle layer thick, and the %s acts on every layer\n",
           what, sc->bcs[b].loc.line, s->name, k, sc->bcs[b].kind == EJ_BC_PRESSURE ? "load" : "damping");
}


static const char *usage =
    "usage: ejecta <command> [options]\n"
    "\n"
    "commands:\n"
    "  run SCENE [-o FILE] [--threads N] [--restart FILE] [--end TIME]\n"
    "                      run a scene; output HDF5 + XDMF (default: the scene's output.file)\n"
    "  check SCENE         validate a scene, set up its particles, evaluate t = 0; write nothing\n"
    "  plugins             list the plugins found in the search path\n"
    "  describe NAME       parameters, units, bounds and fields of a plugin\n"
    "  describe scene      the core's scene keys (time, output, sets, boundaries, probes)\n"
    "  describe --markdown [NAME] [-o DIR]\n"
    "                      Markdown pages of every plugin (default DIR docs/plugins), or of NAME\n"
    "  schema [-o FILE]    JSON Schema of the scene format (schemas/scene.schema.json)\n"
    "  --version           print the version and build signature\n"
    "\n"
    "Plugins are searched in the build tree, the install prefix, then EJECTA_PLUGIN_PATH.\n"
    "Ctrl-C (SIGINT) or SIGTERM stops a run after its current step and keeps its state in\n"
    "FILE.partial for --restart (exit 130 / 143); a second one aborts.\n";

static int ej_exit_code(ej_err rc)
{
  switch (rc) {
  case EJ_OK: return 0;
  case EJ_ERR_INPUT:
  case EJ_ERR_ABI:
  case EJ_ERR_PLUGIN:
  case EJ_ERR_ARG: return 2;
  default: return 1;
  }
}

static int ej_fail(ej_err rc)
{
  ej_error_report("ejecta");
  return ej_exit_code(rc);
}

static int ej_bad_usage(const char *fmt, const char *arg)
{
  fprintf(stderr, "ejecta: error: ");
  fprintf(stderr, fmt, arg);
  fprintf(stderr, "\n%s", usage);
  return 2;
}

/* SIGINT / SIGTERM during a run: the first asks the run to stop after its current step (it keeps
 * a last frame and a checkpoint in NAME.partial, like LS-DYNA's sense switch sw1); a second one
 * ends the process at once (the default action, re-raised). */
static void ej_on_stop_signal(int signo)
{
  static volatile sig_atomic_t seen;
  if (seen) {
    signal(signo, SIG_DFL);
    raise(signo);
    return;
  }
  seen = 1;
  static const char msg[] = "\nejecta: stopping after this step (the state is kept for --restart; again to abort)\n";
  ssize_t w = write(STDERR_FILENO, msg, sizeof msg - 1);
  (void)w;
  ej_sim_request_stop(signo);
}

static void ej_catch_stop_signals(void)
{
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = ej_on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (int k = 0; k < 2; ++k) {
    const int signo = k ? SIGTERM : SIGINT;
    struct sigaction old;
    /* a shell's background job has SIGINT ignored: keep it so */
    if (sigaction(signo, NULL, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    sigaction(signo, &sa, NULL);
  }
}

static int cmd_run(int argc, char **argv, bool check_only)
{
  const char *scene_path = NULL;
  ej_run_opts opts = {.struct_size = sizeof opts, .progress = isatty(STDERR_FILENO)};
  for (int i = 0; i < argc; ++i) {
    const char *a = argv[i];
    if (!strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--threads") || !strcmp(a, "--restart") ||
        !strcmp(a, "--end")) {
      if (i + 1 >= argc) return ej_bad_usage("option '%s' needs a value", a);
      const char *val = argv[++i];
      if (!strcmp(a, "--threads")) {
        char *end;
        long n = strtol(val, &end, 10);
        if (*end || n < 1 || n > 4096) return ej_bad_usage("--threads expects a positive integer, got '%s'", val);
        opts.threads = (int)n;
      } else if (!strcmp(a, "--restart")) {
        opts.restart = val;
      } else if (!strcmp(a, "--end")) {
        double t;
        ej_loc loc = {"--end", 0, 0};
        if (ej_units_parse(val, "s", &loc, &t) != EJ_OK || t <= 0) {
          ej_error_clear();
          return ej_bad_usage("--end expects a positive time such as '0.2 ms', got '%s'", val);
        }
        opts.t_end = t;
      } else {
        opts.output = val;
      }
    } else if (!strcmp(a, "--no-progress")) {
      opts.progress = false;
    } else if (a[0] == '-' && a[1]) {
      return ej_bad_usage("unknown option '%s'", a);
    } else if (!scene_path) {
      scene_path = a;
    } else {
      return ej_bad_usage("unexpected argument '%s'", a);
    }
  }
  if (!scene_path) return ej_bad_usage("%s needs a scene file", check_only ? "check" : "run");
  opts.check_only = check_only;
  /* from here: a signal during the set-up stops the run after its first step */
  if (!check_only) ej_catch_stop_signals();
  ej_registry *reg = NULL;
  ej_scene *scene = NULL;
  ej_sim *sim = NULL;
  int stopped = 0; /* the exit code of a run stopped by a signal: 128 + the signal */
  ej_err rc;
  EJ_TRY_GOTO(rc, ej_registry_create(&reg), out);
  EJ_TRY_GOTO(rc, ej_scene_load(scene_path, reg, &scene), out);
  EJ_TRY_GOTO(rc, ej_sim_create(scene, reg, &opts, &sim), out);
  if (check_only) {
    long long total = 0;
    for (int i = 0; i < sim->n_sets; ++i) {
      const ej_set *s = sim->sets[i];
      printf("set '%s': %d particles, method %s, material %s\n", s->name, (int)s->n, s->mops->name, s->model->name);
      total += s->n;
    }
    for (int k = 0; k < sim->n_probes; ++k) { /* where each probe measures, to check before a long run */
      const ej_probe *P = &sim->probes[k];
      const ej_set *s = P->set;
      const ej_real *x = ej_set_field(s, "x"), *pt = P->sp->point;
      if (P->sp->follow) {
        printf("probe '%s': tracer of particle id %d of set '%s', at (%g, %g, %g) m, %d columns\n", P->sp->name,
               (int)P->id, s->name, x[3 * P->at], x[3 * P->at + 1], x[3 * P->at + 2], P->n_cols);
        continue;
      }
      ej_real d2;
      ej_set_nearest(s, sim->dim, pt, &d2);
      printf("probe '%s': gauge in set '%s' at (%g, %g, %g) m, nearest particle %g m away, %d columns\n", P->sp->name,
             s->name, pt[0], pt[1], pt[2], sqrt(d2), P->n_cols);
    }
    for (int b = 0; b < scene->n_bcs; ++b) { /* the dashpots' share of the boundary: one layer gives its area */
      if (scene->bcs[b].kind != EJ_BC_NONREFLECT) continue;
      for (int i = 0; i < sim->n_sets; ++i) {
        const ej_set *s = sim->sets[i];
        if (!(s->nr_bits & (1u << b))) continue;
        const ej_real *vol0 = ej_set_field(s, "vol0");
        int n = 0;
        double area = 0;
        for (ej_idx p = 0; p < s->n; ++p)
          if (s->bc_mask[p] & (1u << b)) {
            ++n;
            area += ej_face_area(scene->dimension, vol0[p]);
          }
        printf("non_reflecting (line %d) on set '%s': %d particles, boundary %g %s, rho c_p %g, rho c_s %g kg/(m^2 s)\n",
               scene->bcs[b].loc.line, s->name, n, area,
               scene->dimension == 3 ? "m^2" : scene->dimension == 2 ? "m (per m of thickness)" : "(1D)", s->nr_zp[b],
               s->nr_zs[b]);
        ej_face_warn(scene, s, b, "non_reflecting");
      }
    }
    for (int b = 0; b < scene->n_bcs; ++b) { /* each pressure load: its face, and what a blast puts on it */
      const ej_scene_bc *bc = &scene->bcs[b];
      if (bc->kind != EJ_BC_PRESSURE) continue;
      for (int i = 0; i < sim->n_sets; ++i) {
        const ej_set *s = sim->sets[i];
        if (!(s->pr_bits & (1u << b))) continue;
        const ej_real *vol0 = ej_set_field(s, "vol0"), *x = ej_set_field(s, "x");
        int n = 0;
        double area = 0, zlo = INFINITY, zhi = 0, tlo = INFINITY, thi = 0, plo = INFINITY, phi = 0, imp = 0;
        for (ej_idx p = 0; p < s->n; ++p) {
          if (!(s->bc_mask[p] & (1u << b))) continue;
          const ej_real A = ej_face_area(scene->dimension, vol0[p]);
          ++n;
          area += A;
          ej_real nv[3];
          if (bc->source != EJ_PRESSURE_BLAST || !ej_bc_face_normal(bc, x + 3 * p, nv)) continue;
          ej_blast_face f;
          ej_blast_peak(bc->burst, bc->tnt, bc->charge, x + 3 * p, nv, &f);
          zlo = fmin(zlo, f.z), zhi = fmax(zhi, f.z);
          tlo = fmin(tlo, f.t_a), thi = fmax(thi, f.t_a);
          plo = fmin(plo, f.p), phi = fmax(phi, f.p);
          imp += A * f.impulse;
        }
        const char *unit = scene->dimension == 3 ? "m^2" : scene->dimension == 2 ? "m (per m of thickness)" : "(1D)";
        printf("pressure (line %d) on set '%s': %d particles, face %g %s", bc->loc.line, s->name, n, area, unit);
        if (bc->source == EJ_PRESSURE_BLAST)
          printf("; %g kg TNT %s burst: Z %.4g-%.4g m/kg^(1/3), arrival %.4g-%.4g s after detonation, peak %.4g-%.4g "
                 "Pa, impulse on the face %.4g N s%s\n",
                 bc->tnt, bc->burst == EJ_BURST_SURFACE ? "surface" : "air", zlo, zhi, tlo, thi, plo, phi, imp,
                 scene->dimension == 2 ? " per m" : "");
        else printf("\n");
        ej_face_warn(scene, s, b, "pressure");
        if (!s->model->mat)
          printf("warning: pressure (line %d) on set '%s': material '%s' has no strength model (a fluid): the load "
                 "pushes the surface particles, which do not hold together as a face; in SPH it does not act as a "
                 "piston (docs/core.md \"Pressure loads\": use a wall or a piston set)\n",
                 bc->loc.line, s->name, s->model->name);
      }
    }
    printf("%s: OK (%lld particles, dimension %d, end time %g s)\n", scene_path, total, scene->dimension,
           scene->t_end);
  } else {
    EJ_TRY_GOTO(rc, ej_sim_run(sim), out);
    const int sig = ej_sim_stop_signal(sim);
    if (sig) {
      fprintf(stderr,
              "ejecta: stopped by %s at step %lld, t = %g s (end %g s); a last frame and a checkpoint are in "
              "%s.partial; continue with: ejecta run %s --restart %s.partial\n",
              sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a stop request", (long long)sim->step, sim->t,
              scene->t_end, sim->out_path, scene_path, sim->out_path);
      stopped = 128 + (sig > 0 ? sig : 0);
      goto out;
    }
    printf("ejecta: wrote %s (%lld steps, %lld neighbour rebuilds, t = %g s; open %.*s.xdmf in ParaView)\n",
           sim->out_path, (long long)sim->step, (long long)sim->n_rebuilds, sim->t, (int)(strrchr(sim->out_path, '.') ? strrchr(sim->out_path, '.') - sim->out_path
                                                                            : (long)strlen(sim->out_path)),
           sim->out_path);
    for (int i = 0; i < sim->n_sets; ++i) {
      const ej_set *s = sim->sets[i];
      ej_counter cnt[16];
      int nc = 0;
      if (s->mops->counters && s->mops->counters(s->mstate, cnt, 16, &nc) == EJ_OK)
        for (int k = 0; k < nc; ++k) printf("ejecta: set '%s': %s: %lld\n", s->name, cnt[k].name, (long long)cnt[k].value);
    }
    /* relative to the initial total; a run that starts with none (a body at rest loaded by gravity or
     * a pressure) is measured against the external work instead, never printed as 0 of nothing */
    const ej_energy *en = &sim->energy;
    if (en->total0 != 0)
      printf("ejecta: energy balance error %.3e J (%.3e of the initial total)\n", en->balance, en->balance / en->total0);
    else if (en->external != 0)
      printf("ejecta: energy balance error %.3e J (%.3e of the external work; the initial total is 0)\n", en->balance,
             en->balance / fabs(en->external));
    else
      printf("ejecta: energy balance error %.3e J (the initial total and the external work are 0)\n", en->balance);
  }
out:
  if (rc != EJ_OK) {
    int code = ej_fail(rc);
    ej_sim_destroy(sim);
    ej_scene_destroy(scene);
    ej_registry_destroy(reg);
    return code;
  }
  ej_sim_destroy(sim);
  ej_scene_destroy(scene);
  ej_registry_destroy(reg);
  return stopped;
}

static void ej_print_warnings(void)
{
  for (int k = 0; k < ej_error_count(); ++k) {
    const ej_error_frame *f = ej_error_frame_at(k);
    if (f->msg[0]) fprintf(stderr, "ejecta: warning: %s\n", f->msg);
  }
  ej_error_clear();
}

static int cmd_plugins(void)
{
  ej_registry *reg;
  ej_err rc = ej_registry_create(&reg);
  if (rc != EJ_OK) return ej_fail(rc);
  (void)ej_registry_load_all(reg);
  ej_print_warnings();
  for (int i = 0; i < ej_registry_plugin_count(reg); ++i) {
    const char *path;
    const ej_plugin_info *info = ej_registry_plugin(reg, i, &path);
    printf("%-20s %-8s %s\n", info->name, info->version ? info->version : "?", path);
  }
  for (int k = 0; k < EJ_KIND_COUNT; ++k)
    for (int i = 0; i < ej_registry_count(reg, (ej_kind)k); ++i) {
      const ej_ops_head *h = ej_registry_item(reg, (ej_kind)k, i);
      printf("  %-12s %-18s %s\n", ej_kind_name((ej_kind)k), h->name, h->summary);
    }
  ej_registry_destroy(reg);
  return 0;
}

/* ------------------------------------------------------------------ describe --markdown */

/* The fields a method declares with its default parameters (3D), as Markdown rows. */
static ej_err ej_md_fields(ej_buf *b, const ej_method_ops *m)
{
  void *cfg = ej_calloc(1, m->config_size ? m->config_size : 1);
  ej_set *s = NULL;
  ej_err rc = cfg ? EJ_OK : EJ_ERR_MEM;
  if (rc == EJ_OK) rc = ej_params_defaults(m->params, cfg);
  if (rc == EJ_OK) rc = ej_set_create("describe", 0, 3, &s);
  if (rc == EJ_OK) {
    int base = s->n_fields;
    if (ej_decl_probe(m, cfg, s) == EJ_OK && s->n_fields > base) {
      rc = ej_buf_printf(b, "\n## Fields\n\nDeclared with the default parameters in 3D (a configuration may add or "
                            "drop some).\n\n| field | kind | unit | integrated | output |\n|---|---|---|---|---|\n");
      for (int k = base; k < s->n_fields && rc == EJ_OK; ++k) {
        const ej_field *f = &s->fields[k];
        if (f->flags & EJ_FIELD_SCRATCH && f->half < 0 && strstr(f->name, "_half")) continue;
        rc = ej_buf_printf(b, "| `%s` | %s | %s | %s | %s |\n", f->name, ej_field_kind_name(f->kind),
                           f->unit && *f->unit ? f->unit : "-", f->rate_of >= 0 ? "rate" : (f->rate >= 0 ? "yes" : "-"),
                           (f->flags & EJ_FIELD_OUTPUT) ? "yes" : "-");
      }
    }
    ej_error_clear();
  }
  ej_set_destroy(s);
  ej_free(cfg);
  return rc;
}

/* One plugin's page: summary, doc, parameter table and what the core needs to know of it. */
static ej_err ej_md_page(ej_buf *b, ej_kind kind, const ej_ops_head *h)
{
  EJ_TRY(ej_buf_printf(b, "<!-- Generated by `ejecta describe --markdown`; do not edit. -->\n# %s (%s)\n\n%s\n",
                       h->name, ej_kind_name(kind), h->summary ? h->summary : ""));
  if (h->doc) EJ_TRY(ej_buf_printf(b, "\n%s\n", h->doc));
  static const char *const blocks[] = {"sets: {NAME: {method: %s, ...}}", "materials: {NAME: {model: %s, ...}}",
                                       "materials: {NAME: {rho0: ..., eos: {model: %s, ...}}}", "interactions: [{model: %s, sets: [...], ...}]"};
  EJ_TRY(ej_buf_printf(b, "\nScene usage: `"));
  EJ_TRY(ej_buf_printf(b, blocks[kind], h->name));
  EJ_TRY(ej_buf_printf(b, "`\n\n## Parameters\n\nNumbers may carry any unit of the stated dimension "
                          "(`8.7 GPa`, `4 mm`); bounds are in the stated unit.\n\n"));
  EJ_TRY(ej_params_markdown(b, h->params));
  if (kind == EJ_KIND_MATERIAL) {
    const ej_material_ops *m = (const ej_material_ops *)h;
    EJ_TRY(ej_buf_printf(b, "\n## Material\n\n- needs an EOS: %s\n- history variables:", m->needs_eos ? "yes" : "no"));
    if (m->n_hist == 0) EJ_TRY(ej_buf_printf(b, " none"));
    for (int k = 0; k < m->n_hist; ++k) EJ_TRY(ej_buf_printf(b, "%s `%s`", k ? "," : "", m->hist_names[k]));
    EJ_TRY(ej_buf_printf(b, "\n"));
  } else if (kind == EJ_KIND_METHOD) {
    EJ_TRY(ej_md_fields(b, (const ej_method_ops *)h));
  } else if (kind == EJ_KIND_INTERACTION) {
    const ej_interaction_ops *in = (const ej_interaction_ops *)h;
    bool both = h->struct_size >= offsetof(ej_interaction_ops, both_ways) + sizeof in->both_ways && in->both_ways;
    EJ_TRY(ej_buf_printf(b, "\n## Interaction\n\n- acts both ways: %s\n", both ? "yes" : "no"));
  }
  return EJ_OK;
}

static int ej_md_cmp(const void *a, const void *b)
{
  const ej_ops_head *const *x = a, *const *y = b;
  return strcmp((*x)->name, (*y)->name);
}

static ej_err ej_md_write(const char *dir, const char *name, const ej_buf *b)
{
  char path[4096];
  snprintf(path, sizeof path, "%s/%s.md", dir, name);
  FILE *f = fopen(path, "w");
  EJ_ENSURE(f, EJ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
  bool ok = fwrite(b->data, 1, b->len, f) == b->len;
  ok = fclose(f) == 0 && ok;
  EJ_ENSURE(ok, EJ_ERR_IO, "cannot write '%s'", path);
  return EJ_OK;
}

/* docs/plugins/<name>.md for every plugin found, plus README.md, an index by kind. */
static int cmd_describe_markdown(ej_registry *reg, const char *only, const char *dir)
{
  ej_err rc = EJ_OK;
  ej_buf index = {0};
  rc = ej_buf_printf(&index, "<!-- Generated by `ejecta describe --markdown`; do not edit. -->\n# Plugins\n\n"
                             "One page per plugin, generated from its parameter table "
                             "(`ejecta describe --markdown -o docs/plugins`).\n");
  bool found = false;
  for (int k = 0; k < EJ_KIND_COUNT && rc == EJ_OK; ++k) {
    int n = ej_registry_count(reg, (ej_kind)k);
    if (n == 0) continue;
    const ej_ops_head **list = ej_calloc((size_t)n, sizeof *list);
    if (!list) {
      rc = EJ_ERR_MEM;
      break;
    }
    for (int i = 0; i < n; ++i) list[i] = ej_registry_item(reg, (ej_kind)k, i);
    qsort(list, (size_t)n, sizeof *list, ej_md_cmp);
    rc = ej_buf_printf(&index, "\n## %s\n\n| plugin | summary |\n|---|---|\n", ej_kind_name((ej_kind)k));
    for (int i = 0; i < n && rc == EJ_OK; ++i) {
      if (only && strcmp(only, list[i]->name)) continue;
      found = true;
      ej_buf page = {0};
      rc = ej_md_page(&page, (ej_kind)k, list[i]);
      if (rc == EJ_OK && !dir) fwrite(page.data, 1, page.len, stdout);
      if (rc == EJ_OK && dir) rc = ej_md_write(dir, list[i]->name, &page);
      ej_buf_free(&page);
      if (rc == EJ_OK) rc = ej_buf_printf(&index, "| [%s](%s.md) | %s |\n", list[i]->name, list[i]->name,
                                          list[i]->summary ? list[i]->summary : "");
    }
    ej_free(list);
  }
  if (rc == EJ_OK && dir && !only) rc = ej_md_write(dir, "README", &index);
  ej_buf_free(&index);
  if (rc == EJ_OK && only && !found) {
    fprintf(stderr, "ejecta: error: no plugin named '%s' (see 'ejecta plugins')\n", only);
    return 2;
  }
  if (rc != EJ_OK) return ej_fail(rc);
  if (dir) printf("ejecta: wrote the plugin pages to %s/\n", dir);
  return 0;
}

static int cmd_describe(int argc, char **argv)
{
  const char *name = NULL, *md_dir = NULL;
  bool markdown = false;
  for (int i = 0; i < argc; ++i) {
    if (!strcmp(argv[i], "--markdown")) markdown = true;
    else if (!strcmp(argv[i], "-o") && i + 1 < argc) md_dir = argv[++i];
    else if (argv[i][0] == '-') return ej_bad_usage("unknown option '%s'", argv[i]);
    else if (!name) name = argv[i];
    else return ej_bad_usage("unexpected argument '%s'", argv[i]);
  }
  if (md_dir && !markdown) return ej_bad_usage("%s", "-o DIR goes with --markdown");
  if (markdown) {
    ej_registry *reg;
    ej_err rc = ej_registry_create(&reg);
    if (rc != EJ_OK) return ej_fail(rc);
    (void)ej_registry_load_all(reg);
    ej_error_clear();
    int code = cmd_describe_markdown(reg, name, md_dir ? md_dir : (name ? NULL : "docs/plugins"));
    ej_registry_destroy(reg);
    return code;
  }
  if (!name) return ej_bad_usage("%s", "describe needs a plugin name (see 'ejecta plugins') or 'scene'");
  if (!strcmp(name, "scene")) { /* the core's keys (a plugin cannot be named so: it would be shadowed) */
    ej_buf b = {0};
    ej_err rc = ej_scene_describe(&b);
    if (rc == EJ_OK && b.data) fputs(b.data, stdout);
    ej_buf_free(&b);
    return rc == EJ_OK ? 0 : ej_fail(rc);
  }
  ej_registry *reg;
  ej_err rc = ej_registry_create(&reg);
  if (rc != EJ_OK) return ej_fail(rc);
  (void)ej_registry_load_all(reg);
  ej_error_clear();
  const ej_ops_head *h = NULL;
  ej_kind kind = EJ_KIND_METHOD;
  const char *cands[512];
  int nc = 0;
  for (int k = 0; k < EJ_KIND_COUNT; ++k)
    for (int i = 0; i < ej_registry_count(reg, (ej_kind)k); ++i) {
      const ej_ops_head *o = ej_registry_item(reg, (ej_kind)k, i);
      if (nc < 512) cands[nc++] = o->name;
      if (!strcmp(o->name, name)) h = o, kind = (ej_kind)k;
    }
  if (!h) {
    const char *near = ej_nearest_word(name, cands, nc);
    fprintf(stderr, "ejecta: error: no plugin named '%s'%s%s%s\n", name, near ? "; did you mean '" : "",
            near ? near : "", near ? "'?" : "");
    ej_registry_destroy(reg);
    return 2;
  }
  ej_buf b = {0};
  printf("%s %s: %s\n", ej_kind_name(kind), h->name, h->summary);
  if (h->doc) printf("\n%s\n", h->doc);
  printf("\nparameters:\n");
  if (h->params && h->params[0].name) {
    rc = ej_params_describe(&b, h->params, 2);
    if (rc == EJ_OK && b.data) fputs(b.data, stdout);
  } else {
    printf("  (none)\n");
  }
  if (kind == EJ_KIND_METHOD && rc == EJ_OK) {
    const ej_method_ops *m = (const ej_method_ops *)h;
    void *cfg = ej_calloc(1, m->config_size ? m->config_size : 1);
    ej_set *s = NULL;
    if (cfg && ej_params_defaults(m->params, cfg) == EJ_OK && ej_set_create("describe", 0, 3, &s) == EJ_OK) {
      int base = s->n_fields;
      ej_decl_probe(m, cfg, s);
      printf("\nfields (with default parameters, 3D):\n");
      for (int k = base; k < s->n_fields; ++k) {
        const ej_field *f = &s->fields[k];
        if (f->flags & EJ_FIELD_SCRATCH && f->half < 0 && strstr(f->name, "_half")) continue;
        printf("  %-14s %-8s %-10s%s%s\n", f->name, ej_field_kind_name(f->kind), f->unit ? f->unit : "",
               f->rate_of >= 0 ? " rate" : "", (f->flags & EJ_FIELD_OUTPUT) ? " output" : "");
      }
    }
    ej_error_clear();
    ej_set_destroy(s);
    ej_free(cfg);
  }
  ej_buf_free(&b);
  ej_registry_destroy(reg);
  return rc == EJ_OK ? 0 : ej_fail(rc);
}

static int cmd_schema(int argc, char **argv)
{
  const char *out = NULL;
  for (int i = 0; i < argc; ++i) {
    if (!strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
    else return ej_bad_usage("unexpected argument '%s'", argv[i]);
  }
  ej_registry *reg;
  ej_err rc = ej_registry_create(&reg);
  if (rc != EJ_OK) return ej_fail(rc);
  (void)ej_registry_load_all(reg);
  ej_error_clear();
  ej_buf b = {0};
  rc = ej_scene_schema(reg, &b);
  if (rc == EJ_OK) {
    FILE *f = out ? fopen(out, "w") : stdout;
    if (!f) {
      fprintf(stderr, "ejecta: error: cannot write '%s': %s\n", out, strerror(errno));
      ej_buf_free(&b);
      ej_registry_destroy(reg);
      return 2;
    }
    fwrite(b.data, 1, b.len, f);
    if (out) fclose(f);
  }
  ej_buf_free(&b);
  ej_registry_destroy(reg);
  return rc == EJ_OK ? 0 : ej_fail(rc);
}

int main(int argc, char **argv)
{
  if (argc < 2 || !strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
    fputs(usage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  const char *cmd = argv[1];
  if (!strcmp(cmd, "--version") || !strcmp(cmd, "version")) {
    printf("ejecta %s (%s)\n", EJ_VERSION, EJ_BUILD_SIGNATURE);
    return 0;
  }
  if (!strcmp(cmd, "run")) return cmd_run(argc - 2, argv + 2, false);
  if (!strcmp(cmd, "check")) return cmd_run(argc - 2, argv + 2, true);
  if (!strcmp(cmd, "plugins")) return cmd_plugins();
  if (!strcmp(cmd, "describe")) return cmd_describe(argc - 2, argv + 2);
  if (!strcmp(cmd, "schema")) return cmd_schema(argc - 2, argv + 2);
  static const char *cmds[] = {"run", "check", "plugins", "describe", "schema"};
  const char *near = ej_nearest_word(cmd, cmds, 5);
  fprintf(stderr, "ejecta: error: unknown command '%s'%s%s%s\n%s", cmd, near ? "; did you mean '" : "",
          near ? near : "", near ? "'?" : "", usage);
  return 2;
}
