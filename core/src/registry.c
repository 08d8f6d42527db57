/* Per-run plugin registry and the dlopen loader (DESIGN.md "Plugins"; house style §3.5).
 *
 * A plugin file is ej_<name>.so and is looked up by the name a scene uses. The loader checks
 * the frozen head of ej_plugin_info (ABI major/minor, build signature) before trusting
 * anything else, validates every ops table at registration, unwinds a file's registrations if
 * any of them fails, and never dlcloses (OpenMP runtimes crash on unload). */
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core_impl.h"

#define EJ_MAX_DIRS 32

typedef struct ej_reg_item {
  const void *ops;
  int plugin; /* index into plugins, -1 = registered directly (tests) */
} ej_reg_item;

typedef struct ej_reg_plugin {
  const ej_plugin_info *info;
  char *path;
} ej_reg_plugin;

struct ej_registry {
  char *dirs[EJ_MAX_DIRS];
  int n_dirs;
  ej_reg_item *items[EJ_KIND_COUNT];
  int n_items[EJ_KIND_COUNT], cap_items[EJ_KIND_COUNT];
  ej_reg_plugin *plugins;
  int n_plugins, cap_plugins;
  int loading; /* plugin index whose register_all is running, -1 otherwise */
  char **tried; /* names already searched for */
  int n_tried;
};

const char *ej_kind_name(ej_kind k)
{
  static const char *names[] = {"method", "material", "eos", "interaction"};
  return (k >= 0 && k < EJ_KIND_COUNT) ? names[k] : "plugin";
}

static void ej_registry_clear_dirs(ej_registry *reg)
{
  for (int i = 0; i < reg->n_dirs; ++i) ej_free(reg->dirs[i]);
  reg->n_dirs = 0;
}

static ej_err ej_registry_add_dirs(ej_registry *reg, const char *list)
{
  if (!list) return EJ_OK;
  const char *p = list;
  while (*p) {
    const char *end = strchr(p, ':');
    size_t len = end ? (size_t)(end - p) : strlen(p);
    if (len && reg->n_dirs < EJ_MAX_DIRS) {
      char *d = ej_malloc(len + 1);
      EJ_ENSURE(d, EJ_ERR_MEM, "out of memory");
      memcpy(d, p, len);
      d[len] = 0;
      reg->dirs[reg->n_dirs++] = d;
    }
    if (!end) break;
    p = end + 1;
  }
  return EJ_OK;
}

ej_err ej_registry_set_path(ej_registry *reg, const char *path)
{
  ej_registry_clear_dirs(reg);
  return ej_registry_add_dirs(reg, path);
}

ej_err ej_registry_create(ej_registry **out)
{
  ej_registry *reg = ej_calloc(1, sizeof *reg);
  EJ_ENSURE(reg, EJ_ERR_MEM, "out of memory");
  reg->loading = -1;
  ej_err rc;
  /* Search order: build tree, install prefix, then EJECTA_PLUGIN_PATH. */
  EJ_TRY_GOTO(rc, ej_registry_add_dirs(reg, EJ_PLUGIN_BUILD_DIR), out_destroy);
  EJ_TRY_GOTO(rc, ej_registry_add_dirs(reg, EJ_PLUGIN_INSTALL_DIR), out_destroy);
  EJ_TRY_GOTO(rc, ej_registry_add_dirs(reg, getenv("EJECTA_PLUGIN_PATH")), out_destroy);
  *out = reg;
  return EJ_OK;
out_destroy:
  ej_registry_destroy(reg);
  return rc;
}

void ej_registry_destroy(ej_registry *reg)
{
  if (!reg) return;
  ej_registry_clear_dirs(reg);
  for (int k = 0; k < EJ_KIND_COUNT; ++k) ej_free(reg->items[k]);
  for (int i = 0; i < reg->n_plugins; ++i) ej_free(reg->plugins[i].path);
  ej_free(reg->plugins);
  for (int i = 0; i < reg->n_tried; ++i) ej_free(reg->tried[i]);
  ej_free(reg->tried);
  ej_free(reg); /* plugin handles stay open on purpose: never dlclose */
}

/* ------------------------------------------------------------------ ops validation */

static const char *ej_ops_name(ej_kind k, const void *ops)
{
  (void)k;
  return ((const ej_ops_head *)ops)->name;
}

static const void *ej_registry_find(const ej_registry *reg, ej_kind k, const char *name)
{
  for (int i = 0; i < reg->n_items[k]; ++i)
    if (!strcmp(ej_ops_name(k, reg->items[k][i].ops), name)) return reg->items[k][i].ops;
  return NULL;
}

static const char *ej_registry_origin(const ej_registry *reg, ej_kind k, const char *name)
{
  for (int i = 0; i < reg->n_items[k]; ++i)
    if (!strcmp(ej_ops_name(k, reg->items[k][i].ops), name))
      return reg->items[k][i].plugin >= 0 ? reg->plugins[reg->items[k][i].plugin].path : "built-in";
  return "?";
}

static size_t ej_param_size(const ej_param *p)
{
  switch (p->type) {
  case EJ_PT_REAL: return sizeof(ej_real);
  case EJ_PT_INT: return sizeof(int64_t);
  case EJ_PT_BOOL: return sizeof(bool);
  case EJ_PT_ENUM: return sizeof(int);
  case EJ_PT_STRING: return sizeof(const char *);
  case EJ_PT_REAL_ARRAY: return (size_t)p->count * sizeof(ej_real);
  case EJ_PT_BLOCK: return p->sub_size;
  }
  return 0;
}

/* A malformed table fails at load, not in the middle of a run. */
static ej_err ej_params_check_table(const char *owner, const ej_param *t, size_t config_size)
{
  if (!t) return EJ_OK;
  for (int i = 0; t[i].name; ++i) {
    const ej_param *p = &t[i];
    for (int j = 0; j < i; ++j)
      EJ_ENSURE(strcmp(t[j].name, p->name), EJ_ERR_PLUGIN, "%s: parameter '%s' declared twice", owner, p->name);
    EJ_ENSURE(p->doc && p->doc[0], EJ_ERR_PLUGIN, "%s: parameter '%s' has no doc string", owner, p->name);
    EJ_ENSURE(p->offset + ej_param_size(p) <= config_size, EJ_ERR_PLUGIN,
              "%s: parameter '%s' lies outside the config struct (offset %zu, config_size %zu)", owner, p->name,
              p->offset, config_size);
    if (p->type == EJ_PT_REAL && !(p->flags & EJ_PF_REQUIRED)) {
      EJ_ENSURE(!(p->flags & EJ_PF_HAS_MIN) || p->def > p->min || (p->def == p->min && !(p->flags & EJ_PF_MIN_OPEN)),
                EJ_ERR_PLUGIN, "%s: default of '%s' (%g) is below its minimum %g", owner, p->name, p->def, p->min);
      EJ_ENSURE(!(p->flags & EJ_PF_HAS_MAX) || p->def < p->max || (p->def == p->max && !(p->flags & EJ_PF_MAX_OPEN)),
                EJ_ERR_PLUGIN, "%s: default of '%s' (%g) is above its maximum %g", owner, p->name, p->def, p->max);
    }
    if (p->type == EJ_PT_ENUM) {
      EJ_ENSURE(p->choices && p->choices[0], EJ_ERR_PLUGIN, "%s: enum parameter '%s' has no choices", owner, p->name);
      if (p->def_str) {
        bool found = false;
        for (int c = 0; p->choices[c]; ++c) found |= !strcmp(p->choices[c], p->def_str);
        EJ_ENSURE(found, EJ_ERR_PLUGIN, "%s: default '%s' of '%s' is not one of its choices", owner, p->def_str,
                  p->name);
      }
    }
    if (p->type == EJ_PT_REAL_ARRAY) EJ_ENSURE(p->count > 0, EJ_ERR_PLUGIN, "%s: array '%s' has no length", owner, p->name);
    if (p->type == EJ_PT_BLOCK) {
      EJ_ENSURE(p->sub, EJ_ERR_PLUGIN, "%s: block '%s' has no table", owner, p->name);
      EJ_TRY(ej_params_check_table(owner, p->sub, p->sub_size));
    }
  }
  return EJ_OK;
}

#define EJ_MEMBER_END(type, member) (offsetof(type, member) + sizeof(((type *)0)->member))

static ej_err ej_validate_ops(ej_kind k, const void *ops)
{
  EJ_ENSURE(ops, EJ_ERR_PLUGIN, "NULL %s ops table", ej_kind_name(k));
  const ej_ops_head *h = ops;
  EJ_ENSURE(h->struct_size >= EJ_MEMBER_END(ej_ops_head, check_config), EJ_ERR_PLUGIN,
            "%s ops table too small (struct_size %zu)", ej_kind_name(k), h->struct_size);
  EJ_ENSURE(h->name && h->name[0], EJ_ERR_PLUGIN, "%s ops table without a name", ej_kind_name(k));
  for (const char *c = h->name; *c; ++c)
    EJ_ENSURE((*c >= 'a' && *c <= 'z') || (*c >= '0' && *c <= '9') || *c == '_', EJ_ERR_PLUGIN,
              "%s name '%s' must be lower snake_case", ej_kind_name(k), h->name);
  EJ_ENSURE(h->summary && h->summary[0], EJ_ERR_PLUGIN, "%s '%s' has no summary", ej_kind_name(k), h->name);
  char owner[160];
  snprintf(owner, sizeof owner, "%s '%s'", ej_kind_name(k), h->name);
  EJ_TRY(ej_params_check_table(owner, h->params, h->config_size));
  const char *missing = NULL;
  switch (k) {
  case EJ_KIND_METHOD: {
    const ej_method_ops *m = ops;
    EJ_ENSURE(m->struct_size >= EJ_MEMBER_END(ej_method_ops, destroy), EJ_ERR_PLUGIN,
              "%s: ops table too small (struct_size %zu < %zu)", owner, m->struct_size,
              EJ_MEMBER_END(ej_method_ops, destroy));
    if (!m->declare) missing = "declare";
    else if (!m->create) missing = "create";
    else if (!m->support) missing = "support";
    else if (!m->compute) missing = "compute";
    else if (!m->stable_dt) missing = "stable_dt";
    else if (!m->destroy) missing = "destroy";
    EJ_ENSURE(m->n_passes >= 1 && m->n_passes <= 8, EJ_ERR_PLUGIN, "%s: n_passes must be in [1, 8]", owner);
    break;
  }
  case EJ_KIND_MATERIAL: {
    const ej_material_ops *m = ops;
    EJ_ENSURE(m->struct_size >= EJ_MEMBER_END(ej_material_ops, destroy), EJ_ERR_PLUGIN, "%s: ops table too small",
              owner);
    if (!m->create) missing = "create";
    else if (!m->update) missing = "update";
    else if (!m->destroy) missing = "destroy";
    else if (m->struct_size >= EJ_MEMBER_END(ej_material_ops, moduli) && !m->moduli) missing = "moduli";
    EJ_ENSURE(m->n_hist >= 0 && m->n_hist <= EJ_MAX_HIST, EJ_ERR_PLUGIN, "%s: at most %d history variables", owner,
              EJ_MAX_HIST);
    EJ_ENSURE(m->n_hist >= 0 && (m->n_hist == 0 || m->hist_names), EJ_ERR_PLUGIN, "%s: history variables need names",
              owner);
    break;
  }
  case EJ_KIND_EOS: {
    const ej_eos_ops *m = ops;
    EJ_ENSURE(m->struct_size >= EJ_MEMBER_END(ej_eos_ops, destroy), EJ_ERR_PLUGIN, "%s: ops table too small", owner);
    if (!m->create) missing = "create";
    else if (!m->evaluate) missing = "evaluate";
    else if (!m->destroy) missing = "destroy";
    break;
  }
  case EJ_KIND_INTERACTION: {
    const ej_interaction_ops *m = ops;
    EJ_ENSURE(m->struct_size >= EJ_MEMBER_END(ej_interaction_ops, destroy), EJ_ERR_PLUGIN,
              "%s: ops table too small", owner);
    if (!m->create) missing = "create";
    else if (!m->compute) missing = "compute";
    else if (!m->destroy) missing = "destroy";
    break;
  }
  default: EJ_FAIL(EJ_ERR_ARG, "bad kind");
  }
  EJ_ENSURE(!missing, EJ_ERR_PLUGIN, "%s: required op '%s' is missing", owner, missing);
  return EJ_OK;
}

static ej_err ej_register(ej_registry *reg, ej_kind k, const void *ops)
{
  EJ_ENSURE(reg, EJ_ERR_ARG, "NULL registry");
  EJ_TRY(ej_validate_ops(k, ops));
  const char *name = ej_ops_name(k, ops);
  for (int kk = 0; kk < EJ_KIND_COUNT; ++kk)
    EJ_ENSURE(!ej_registry_find(reg, (ej_kind)kk, name), EJ_ERR_PLUGIN,
              "duplicate plugin name '%s' (already registered as a %s by %s)", name, ej_kind_name((ej_kind)kk),
              ej_registry_origin(reg, (ej_kind)kk, name));
  if (reg->n_items[k] == reg->cap_items[k]) {
    int cap = reg->cap_items[k] ? 2 * reg->cap_items[k] : 8;
    ej_reg_item *p = ej_realloc(reg->items[k], (size_t)cap * sizeof *p);
    EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
    reg->items[k] = p;
    reg->cap_items[k] = cap;
  }
  reg->items[k][reg->n_items[k]++] = (ej_reg_item){.ops = ops, .plugin = reg->loading};
  return EJ_OK;
}

ej_err ej_register_method(ej_registry *reg, const ej_method_ops *ops) { return ej_register(reg, EJ_KIND_METHOD, ops); }
ej_err ej_register_material(ej_registry *reg, const ej_material_ops *ops)
{
  return ej_register(reg, EJ_KIND_MATERIAL, ops);
}
ej_err ej_register_eos(ej_registry *reg, const ej_eos_ops *ops) { return ej_register(reg, EJ_KIND_EOS, ops); }
ej_err ej_register_interaction(ej_registry *reg, const ej_interaction_ops *ops)
{
  return ej_register(reg, EJ_KIND_INTERACTION, ops);
}

int ej_registry_count(const ej_registry *reg, ej_kind k) { return reg->n_items[k]; }
const void *ej_registry_item(const ej_registry *reg, ej_kind k, int i) { return reg->items[k][i].ops; }
int ej_registry_plugin_count(const ej_registry *reg) { return reg ? reg->n_plugins : 0; }
const ej_plugin_info *ej_registry_plugin(const ej_registry *reg, int i, const char **path)
{
  if (path) *path = reg->plugins[i].path;
  return reg->plugins[i].info;
}

/* ------------------------------------------------------------------ loading */

/* Registers a descriptor (from a file or linked statically); unwinds on failure. */
static ej_err ej_registry_add_plugin(ej_registry *reg, const ej_plugin_info *info, const char *path)
{
  EJ_ENSURE(info, EJ_ERR_PLUGIN, "%s: ej_plugin_info_v1() returned NULL", path);
  EJ_ENSURE(info->struct_size >= EJ_MEMBER_END(ej_plugin_info, build_signature), EJ_ERR_ABI,
            "%s: plugin descriptor too small (struct_size %zu)", path, info->struct_size);
  EJ_ENSURE(info->abi_major == EJ_ABI_MAJOR, EJ_ERR_ABI,
            "%s: plugin built for ABI %u.%u, this core has ABI %d.%d (rebuild the plugin)", path, info->abi_major,
            info->abi_minor, EJ_ABI_MAJOR, EJ_ABI_MINOR);
  EJ_ENSURE(info->abi_minor <= EJ_ABI_MINOR, EJ_ERR_ABI,
            "%s: plugin needs ABI %u.%u, newer than this core's %d.%d (update ejecta)", path, info->abi_major,
            info->abi_minor, EJ_ABI_MAJOR, EJ_ABI_MINOR);
  EJ_ENSURE(info->build_signature && !strcmp(info->build_signature, EJ_BUILD_SIGNATURE), EJ_ERR_ABI,
            "%s: build signature '%s' differs from the core's '%s'", path,
            info->build_signature ? info->build_signature : "(null)", EJ_BUILD_SIGNATURE);
  EJ_ENSURE(info->struct_size >= EJ_MEMBER_END(ej_plugin_info, register_all) && info->register_all && info->name,
            EJ_ERR_PLUGIN, "%s: plugin descriptor lacks a name or register_all", path);
  for (int i = 0; i < reg->n_plugins; ++i)
    EJ_ENSURE(strcmp(reg->plugins[i].info->name, info->name), EJ_ERR_PLUGIN,
              "%s: duplicate plugin '%s' (already loaded from %s)", path, info->name, reg->plugins[i].path);
  if (reg->n_plugins == reg->cap_plugins) {
    int cap = reg->cap_plugins ? 2 * reg->cap_plugins : 8;
    ej_reg_plugin *p = ej_realloc(reg->plugins, (size_t)cap * sizeof *p);
    EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
    reg->plugins = p;
    reg->cap_plugins = cap;
  }
  int before[EJ_KIND_COUNT];
  for (int k = 0; k < EJ_KIND_COUNT; ++k) before[k] = reg->n_items[k];
  char *pcopy = ej_strdup(path);
  EJ_ENSURE(pcopy, EJ_ERR_MEM, "out of memory");
  reg->plugins[reg->n_plugins] = (ej_reg_plugin){.info = info, .path = pcopy};
  reg->loading = reg->n_plugins;
  int depth = ej_error_count();
  ej_err rc = info->register_all(reg);
  reg->loading = -1;
  if (rc != EJ_OK) {
    for (int k = 0; k < EJ_KIND_COUNT; ++k) reg->n_items[k] = before[k];
    ej_free(pcopy);
    /* One message that names the file and says why. */
    char why[EJ_ERROR_MSG_LEN] = "";
    const ej_error_frame *cause = ej_error_cause();
    if (cause) snprintf(why, sizeof why, "%s", cause->msg);
    ej_error_truncate(depth);
    return ej_error_push(EJ_ERR_PLUGIN, __FILE__, __LINE__, __func__, "%s: plugin '%s' failed to register: %s",
                         path, info->name, why[0] ? why : "register_all returned an error");
  }
  reg->n_plugins++;
  return EJ_OK;
}

ej_err ej_registry_add_static(ej_registry *reg, const ej_plugin_info *info)
{
  return ej_registry_add_plugin(reg, info, "(linked)");
}

ej_err ej_registry_load_file(ej_registry *reg, const char *path)
{
  for (int i = 0; i < reg->n_plugins; ++i)
    if (!strcmp(reg->plugins[i].path, path)) return EJ_OK;
  dlerror();
  void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (!h) {
    const char *why = dlerror();
    EJ_FAIL(EJ_ERR_PLUGIN, "%s: cannot load plugin: %s", path, why ? why : "unknown dlopen error");
  }
  union {
    void *obj;
    ej_plugin_info_fn fn;
  } entry;
  entry.obj = dlsym(h, EJ_PLUGIN_ENTRY_SYMBOL);
  EJ_ENSURE(entry.obj, EJ_ERR_PLUGIN, "%s: not an ejecta plugin: it does not export %s()", path,
            EJ_PLUGIN_ENTRY_SYMBOL);
  return ej_registry_add_plugin(reg, entry.fn(), path);
}

static bool ej_file_exists(const char *path)
{
  struct stat st;
  return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static ej_err ej_registry_note_tried(ej_registry *reg, const char *name)
{
  char **p = ej_realloc(reg->tried, (size_t)(reg->n_tried + 1) * sizeof *p);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  reg->tried = p;
  reg->tried[reg->n_tried] = ej_strdup(name);
  EJ_ENSURE(reg->tried[reg->n_tried], EJ_ERR_MEM, "out of memory");
  reg->n_tried++;
  return EJ_OK;
}

/* Loads ej_<name>.so from the first directory of the search path that has it. */
static ej_err ej_registry_load_name(ej_registry *reg, const char *name)
{
  for (int i = 0; i < reg->n_tried; ++i)
    if (!strcmp(reg->tried[i], name)) return EJ_OK;
  EJ_TRY(ej_registry_note_tried(reg, name));
  for (int d = 0; d < reg->n_dirs; ++d) {
    char path[4096];
    snprintf(path, sizeof path, "%s/ej_%s.so", reg->dirs[d], name);
    if (ej_file_exists(path)) return ej_registry_load_file(reg, path);
  }
  return EJ_OK;
}

static int ej_cmp_str(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

ej_err ej_registry_load_all(ej_registry *reg)
{
  ej_err first = EJ_OK;
  for (int d = 0; d < reg->n_dirs; ++d) {
    DIR *dir = opendir(reg->dirs[d]);
    if (!dir) continue;
    char **names = NULL;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(dir))) {
      size_t len = strlen(e->d_name);
      if (len > 6 && !strncmp(e->d_name, "ej_", 3) && !strcmp(e->d_name + len - 3, ".so")) {
        char **p = ej_realloc(names, (size_t)(n + 1) * sizeof *p);
        if (!p) break;
        names = p;
        names[n++] = ej_strdup(e->d_name);
      }
    }
    closedir(dir);
    if (n) qsort(names, (size_t)n, sizeof *names, ej_cmp_str); /* deterministic order */
    for (int i = 0; i < n; ++i) {
      char name[256];
      snprintf(name, sizeof name, "%.*s", (int)(strlen(names[i]) - 6), names[i] + 3);
      bool known = false;
      for (int t = 0; t < reg->n_tried; ++t) known |= !strcmp(reg->tried[t], name);
      if (!known) {
        ej_err rc = ej_registry_note_tried(reg, name);
        if (rc == EJ_OK) {
          char path[4096];
          snprintf(path, sizeof path, "%s/%s", reg->dirs[d], names[i]);
          rc = ej_registry_load_file(reg, path);
        }
        if (rc != EJ_OK && first == EJ_OK) first = rc;
      }
      ej_free(names[i]);
    }
    ej_free(names);
  }
  return first;
}

ej_err ej_registry_require(ej_registry *reg, ej_kind k, const char *name, const ej_loc *loc, const void **ops)
{
  const void *found = ej_registry_find(reg, k, name);
  if (!found) {
    EJ_TRY(ej_registry_load_name(reg, name));
    found = ej_registry_find(reg, k, name);
  }
  if (found) {
    *ops = found;
    return EJ_OK;
  }
  /* Unknown here: look at everything installed to say what would have worked. */
  int depth = ej_error_count();
  (void)ej_registry_load_all(reg);
  ej_error_truncate(depth); /* broken files elsewhere don't matter here */
  for (int kk = 0; kk < EJ_KIND_COUNT; ++kk)
    if (kk != (int)k && ej_registry_find(reg, (ej_kind)kk, name))
      return ej_error_input(loc, "'%s' is %s %s plugin, not %s %s", name, kk == EJ_KIND_EOS ? "an" : "a",
                            ej_kind_name((ej_kind)kk), k == EJ_KIND_EOS ? "an" : "a", ej_kind_name(k));
  const char *cands[256];
  int n = 0;
  char avail[1024] = "";
  size_t used = 0;
  for (int i = 0; i < reg->n_items[k] && n < 256; ++i) {
    cands[n++] = ej_ops_name(k, reg->items[k][i].ops);
    int w = snprintf(avail + used, sizeof avail - used, "%s%s", i ? ", " : "", cands[n - 1]);
    if (w > 0 && used + (size_t)w < sizeof avail) used += (size_t)w;
  }
  const char *near = ej_nearest_word(name, cands, n);
  if (near)
    return ej_error_input(loc, "unknown %s '%s'; did you mean '%s'? (available: %s)", ej_kind_name(k), name, near,
                          avail);
  return ej_error_input(loc, "unknown %s '%s' (available: %s)", ej_kind_name(k), name, n ? avail : "none found");
}
