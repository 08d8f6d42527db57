/* The ejecta command line: run | check | plugins | describe NAME | schema.
 * Exit codes: 0 success, 1 a run that failed (watchdog, numerics, I/O), 2 bad input. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_impl.h"

static const char *usage =
    "usage: ejecta <command> [options]\n"
    "\n"
    "commands:\n"
    "  run SCENE [-o FILE] [--threads N] [--restart FILE] [--end TIME]\n"
    "                      run a scene; output HDF5 + XDMF (default: the scene's output.file)\n"
    "  check SCENE         validate a scene and build its particles without running\n"
    "  plugins             list the plugins found in the search path\n"
    "  describe NAME       parameters, units, bounds and fields of a plugin\n"
    "  schema [-o FILE]    JSON Schema of the scene format (schemas/scene.schema.json)\n"
    "  --version           print the version and build signature\n"
    "\n"
    "Plugins are searched in the build tree, the install prefix, then EJECTA_PLUGIN_PATH.\n";

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
  ej_registry *reg = NULL;
  ej_scene *scene = NULL;
  ej_sim *sim = NULL;
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
    printf("%s: OK (%lld particles, dimension %d, end time %g s)\n", scene_path, total, scene->dimension,
           scene->t_end);
  } else {
    EJ_TRY_GOTO(rc, ej_sim_run(sim), out);
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
    printf("ejecta: energy balance error %.3e J (%.3e of the initial total)\n", sim->energy.balance,
           sim->energy.total0 != 0 ? sim->energy.balance / sim->energy.total0 : 0.0);
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
  return 0;
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

static int cmd_describe(int argc, char **argv)
{
  if (argc < 1) return ej_bad_usage("%s", "describe needs a plugin name (see 'ejecta plugins')");
  const char *name = argv[0];
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
