/* The simulation: sets built from the scene, ghosts for symmetry and periodic boundaries,
 * Verlet-skin neighbour rebuilds, and the explicit velocity-Verlet step (DESIGN.md "Core").
 *
 * The core owns every OpenMP region. Work is cut into fixed-size chunks that do not depend on
 * the thread count; plugins write only their own particles (gather form) and reductions are
 * combined per chunk in chunk order, so results are bitwise identical for any thread count. */
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "core_impl.h"

#define EJ_CHUNK 512
#define EJ_NRED 8 /* energy reduction slots per chunk (ej_sim.set_sums has as many) */
_Static_assert(sizeof(((ej_sim *)0)->set_sums[0]) == EJ_NRED * sizeof(ej_real), "set_sums rows hold EJ_NRED sums");
/* per-chunk scratch: EJ_NRED energy sums, then the step's work, then the watchdog's result */
#define EJ_S_WORK EJ_NRED
#define EJ_S_BADP (EJ_NRED + 1)
#define EJ_S_BADF (EJ_NRED + 2)
#define EJ_NSLOT (EJ_NRED + 3)
#define EJ_CHUNKS_MIN 16 /* a set below 16 x EJ_CHUNK particles is cut into 16 or more chunks */

struct ej_decl {
  ej_set *set;
  ej_err rc;
  uint64_t touched; /* the fields this declare op named (bit k = field k) */
};

ej_err ej_decl_field(ej_decl *d, const ej_field_decl *f)
{
  int k = -1;
  EJ_TRY(ej_set_add_field(d->set, f, &k));
  if (k >= 0 && k < 64) d->touched |= UINT64_C(1) << k;
  return EJ_OK;
}

ej_err ej_decl_neighbours(ej_decl *d, ej_nbr_config config)
{
  EJ_ENSURE(config == EJ_NBR_NONE || config == EJ_NBR_CURRENT || config == EJ_NBR_REFERENCE, EJ_ERR_PLUGIN,
            "invalid neighbour configuration %d", (int)config);
  d->set->nbr_config = config;
  return EJ_OK;
}

ej_err ej_decl_probe(const ej_method_ops *m, const void *config, ej_set *s)
{
  ej_decl d = {.set = s};
  return m->declare(config, s->dim, &d);
}

static double ej_wall(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU time of the calling thread: EJECTA_PROFILE's clock, so that a 1-thread profile on a loaded
 * machine counts the work and not the time the thread waited for a core. */
static double ej_thread_cpu(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ------------------------------------------------------------------ chunked parallel loops */

typedef ej_err (*ej_chunk_fn)(ej_sim *sim, ej_set *s, void *ctx, int64_t chunk, ej_range r);

/* Particles per chunk: EJ_CHUNK, or fewer (a multiple of 64, at least 64) so that a small set
 * still has EJ_CHUNKS_MIN chunks: with 7 chunks of 512 (3487 particles) two threads could not
 * get closer than 4:3 chunks (speed-up <= 1.79). It depends on n only, so the order of every
 * reduction, hence every result, is the same for any thread count. */
static int64_t ej_chunk_size(const ej_set *s)
{
  int64_t c = ((int64_t)s->n + EJ_CHUNKS_MIN - 1) / EJ_CHUNKS_MIN;
  c = (c + 63) / 64 * 64;
  return c < 64 ? 64 : c > EJ_CHUNK ? EJ_CHUNK : c;
}

static int64_t ej_chunk_count(const ej_set *s)
{
  const int64_t cs = ej_chunk_size(s);
  return ((int64_t)s->n + cs - 1) / cs;
}

static ej_range ej_chunk_range(const ej_set *s, int64_t c)
{
  const int64_t cs = ej_chunk_size(s), end = (c + 1) * cs;
  return (ej_range){(ej_idx)(c * cs), (ej_idx)(end < s->n ? end : s->n)};
}

/* EJECTA_PROFILE=2: per-region load-balance profile of the step loop (diagnostic only, file-static,
 * one simulation per process). Each chunk's cost is the CPU time of the thread that ran it
 * (CLOCK_THREAD_CPUTIME_ID: the time the thread waited for a core on a loaded machine is not
 * counted); per region ordinal k within the step it sums the chunk costs (the work), the busiest
 * thread's share as run, and the makespans two idle workers would reach from those costs with the
 * dynamic schedule (each chunk, in order, to the worker that frees first) and with a static one
 * (contiguous halves): a load-independent estimate of the idle-machine imbalance. */
#define EJ_PROF_MAXR 24
#define EJ_PROF_MAXC 4096
#define EJ_PROF_MAXT 64
typedef struct ej_prof_region {
  double work, thr_max, dyn2, stat2, wall, chunks;
  int64_t n;
} ej_prof_region;
static struct {
  int level, k, in_step;
  double cost[EJ_PROF_MAXC];
  double busy[EJ_PROF_MAXT * 8]; /* one cache line per thread */
  ej_prof_region r[EJ_PROF_MAXR];
} ej_prof;

static void ej_prof_region_end(int64_t nch, double wall)
{
  if (!ej_prof.in_step || ej_prof.k >= EJ_PROF_MAXR || nch > EJ_PROF_MAXC) return;
  ej_prof_region *R = &ej_prof.r[ej_prof.k++];
  double work = 0, w[2] = {0, 0}, half = 0, tmax = 0;
  for (int64_t c = 0; c < nch; ++c) {
    work += ej_prof.cost[c];
    w[w[1] < w[0]] += ej_prof.cost[c];
    if (c < (nch + 1) / 2) half += ej_prof.cost[c];
  }
  for (int t = 0; t < EJ_PROF_MAXT; ++t) {
    if (ej_prof.busy[8 * t] > tmax) tmax = ej_prof.busy[8 * t];
    ej_prof.busy[8 * t] = 0;
  }
  R->work += work, R->thr_max += tmax, R->dyn2 += w[0] > w[1] ? w[0] : w[1];
  R->stat2 += half > work - half ? half : work - half;
  R->wall += wall, R->chunks += (double)nch, R->n++;
}

static void ej_prof_print(int64_t steps, double loop, double par)
{
  double work = 0, tmax = 0, dyn = 0, stat = 0, wall = 0;
  fprintf(stderr, "ejecta: region profile, per step [us]: k chunks work busiest-thread dyn2-makespan static2-makespan "
                  "master-wall (imbalance = makespan / (work/2))\n");
  for (int k = 0; k < EJ_PROF_MAXR; ++k) {
    const ej_prof_region *R = &ej_prof.r[k];
    if (!R->n) continue;
    const double f = 1e6 / (double)steps;
    fprintf(stderr, "  %2d %5.1f %9.2f %9.2f %9.2f (%.3f) %9.2f (%.3f) %9.2f\n", k, R->chunks / (double)R->n, f * R->work,
            f * R->thr_max, f * R->dyn2, R->work > 0 ? 2 * R->dyn2 / R->work : 0, f * R->stat2,
            R->work > 0 ? 2 * R->stat2 / R->work : 0, f * R->wall);
    work += R->work, tmax += R->thr_max, dyn += R->dyn2, stat += R->stat2, wall += R->wall;
  }
  const double f = 1e6 / (double)steps;
  fprintf(stderr, "  all     %9.2f %9.2f %9.2f (%.3f) %9.2f (%.3f) %9.2f\n", f * work, f * tmax, f * dyn,
          work > 0 ? 2 * dyn / work : 0, f * stat, work > 0 ? 2 * stat / work : 0, f * wall);
  /* two idle workers (read from a 1-thread run): the main thread's serial time plus each region's
   * dynamic makespan; the time inside the regions that no chunk accounts for (fork/join, the
   * profile's own clock reads) either split between the workers (optimistic) or not at all */
  const double t2 = (loop - par) + dyn, t2c = t2 + (par - work);
#ifdef _OPENMP
  if (omp_get_max_threads() > 1) {
    fprintf(stderr, "  two idle workers: estimated from a 1-thread run only\n");
    return;
  }
#endif
  fprintf(stderr, "  two idle workers: %.2f-%.2f us per step, %.3f-%.3f x this run's %.2f us\n", f * t2, f * t2c,
          t2c > 0 ? loop / t2c : 0, t2 > 0 ? loop / t2 : 0, f * loop);
}

#ifdef _OPENMP
/* The chunk loops' schedule from OMP_SCHEDULE ("static", "dynamic,4", "guided", modifiers such as
 * "nonmonotonic:" ignored), read at every run rather than once by the OpenMP runtime, so that a
 * program running several simulations sees a change; unknown: dynamic, 1 (unset: the affinity
 * schedule of ej_for_chunks). */
static void ej_set_chunk_schedule(const char *env)
{
  omp_sched_t kind = omp_sched_dynamic;
  int chunk = 1;
  if (env && *env) {
    const char *colon = strchr(env, ':');
    const char *k = colon ? colon + 1 : env;
    while (*k == ' ') ++k;
    if (strncmp(k, "static", 6) == 0) kind = omp_sched_static, chunk = 0;
    else if (strncmp(k, "guided", 6) == 0) kind = omp_sched_guided;
    else if (strncmp(k, "auto", 4) == 0) kind = omp_sched_auto;
    const char *comma = strchr(k, ',');
    if (comma && atoi(comma + 1) > 0) chunk = atoi(comma + 1);
  }
  omp_set_schedule(kind, chunk);
}
#endif

/* One chunk of ej_for_chunks: skipped when a lower chunk already failed; a failure records the
 * lowest failing chunk's error frames. */
static inline void ej_chunk_run(ej_sim *sim, ej_set *s, ej_chunk_fn fn, void *ctx, int64_t c, int64_t *failed_chunk,
                                ej_error_frame *frames, int *nframes)
{
  int64_t seen;
#pragma omp atomic read
  seen = *failed_chunk;
  if (seen < c) return;
  const double t_c = ej_prof.level > 1 ? ej_thread_cpu() : 0;
  ej_err rc = fn(sim, s, ctx, c, ej_chunk_range(s, c));
  if (ej_prof.level > 1 && c < EJ_PROF_MAXC) {
    const double dt_c = ej_thread_cpu() - t_c;
    ej_prof.cost[c] = dt_c;
#ifdef _OPENMP
    const int tid = omp_get_thread_num();
#else
    const int tid = 0;
#endif
    if (tid < EJ_PROF_MAXT) ej_prof.busy[8 * tid] += dt_c;
  }
  if (rc != EJ_OK) {
#pragma omp critical(ej_chunk_error)
    {
      if (c < *failed_chunk) {
        *nframes = ej_error_count();
        for (int k = 0; k < *nframes; ++k) frames[k] = *ej_error_frame_at(k);
        *failed_chunk = c;
      }
    }
    ej_error_clear();
  }
}

/* Runs fn over the owned particles of s in chunks; the first error (lowest chunk) wins.
 * Default schedule ("affinity", OMP_SCHEDULE unset): thread t owns the t-th contiguous block of
 * chunks and takes them in order from a counter of its own; a thread that has finished its block
 * takes chunks from the other blocks' counters (t+1, t+2, ...). Every region thus gives a thread
 * the same particles as the region before, which it wrote and still holds in its cache (with
 * `dynamic,1` half of them moved between the cores' caches at every region), and the stealing
 * keeps the balance of a dynamic schedule (a thread that waits for its core loses chunks to the
 * others). OMP_SCHEDULE set: OpenMP's runtime schedule with that value. */
static ej_err ej_for_chunks(ej_sim *sim, ej_set *s, ej_chunk_fn fn, void *ctx)
{
  const int64_t nch = ej_chunk_count(s);
  int64_t failed_chunk = INT64_MAX;
  ej_error_frame frames[EJ_ERROR_MAX_FRAMES];
  int nframes = 0;
  const double t_prof = sim->profile ? ej_thread_cpu() : 0, w_prof = ej_prof.level > 1 ? ej_wall() : 0;
#ifdef _OPENMP
  int nb = 1;
  if (sim->affinity) {
    nb = omp_get_max_threads();
    nb = nb > EJ_MAX_BLOCKS ? EJ_MAX_BLOCKS : nb;
    nb = (int64_t)nb > nch ? (int)nch : nb;
  }
  if (nb > 1) {
    ej_chunk_block *B = sim->blocks;
    for (int t = 0; t < nb; ++t) B[t].next = nch * t / nb, B[t].end = nch * (t + 1) / nb;
#pragma omp parallel num_threads(nb)
    {
      const int t = omp_get_thread_num();
      /* its own block first, then the others' (all of them: the runtime may give fewer threads) */
      for (int k = 0; k < nb; ++k) {
        ej_chunk_block *b = &B[(t + k) % nb];
        for (;;) {
          int64_t c;
#pragma omp atomic capture
          c = b->next++;
          if (c >= b->end) break;
          ej_chunk_run(sim, s, fn, ctx, c, &failed_chunk, frames, &nframes);
        }
      }
    }
  } else
#endif
  {
#pragma omp parallel for schedule(runtime)
    for (int64_t c = 0; c < nch; ++c) ej_chunk_run(sim, s, fn, ctx, c, &failed_chunk, frames, &nframes);
  }
  if (sim->profile) sim->prof_par += ej_thread_cpu() - t_prof, sim->prof_regions++;
  if (ej_prof.level > 1) ej_prof_region_end(nch, ej_wall() - w_prof);
  if (failed_chunk != INT64_MAX) {
    ej_error_import(frames, nframes);
    return ej_error_push(frames[0].code, __FILE__, __LINE__, __func__, NULL);
  }
  return EJ_OK;
}

static ej_err ej_sim_scratch(ej_sim *sim, const ej_set *s)
{
  int64_t need = ej_chunk_count(s) * EJ_NSLOT + EJ_NSLOT;
  if (need <= sim->chunk_scratch_cap) return EJ_OK;
  ej_real *p = ej_realloc(sim->chunk_scratch, (size_t)need * sizeof *p);
  EJ_ENSURE(p, EJ_ERR_MEM, "out of memory");
  sim->chunk_scratch = p;
  sim->chunk_scratch_cap = need;
  return EJ_OK;
}

/* A plugin's create refused its input (EJ_ERR_INPUT without a place): the message is tied to the
 * scene node that configured it, so the user sees FILE:LINE:COL like every other input error. */
static ej_err ej_located(ej_err rc, const ej_loc *loc)
{
  /* a plugin's create refusing a combination the scene asked for (EJ_ERR_UNSUPPORTED: strength
   * without a strength model, a 3D-only model in 2D, an interaction given one set) is bad input
   * too: one located message and exit 2, not an internal error with code frames */
  if (rc != EJ_ERR_INPUT && rc != EJ_ERR_UNSUPPORTED) return rc;
  const ej_error_frame *cause = ej_error_cause();
  if (!cause || cause->where.file) return rc;
  char msg[EJ_ERROR_MSG_LEN];
  snprintf(msg, sizeof msg, "%s", cause->msg);
  ej_error_clear();
  return ej_error_input(loc, "%s", msg);
}

/* ------------------------------------------------------------------ models */

static ej_err ej_models_create(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  sim->models = ej_calloc((size_t)sc->n_materials + 1, sizeof *sim->models);
  EJ_ENSURE(sim->models, EJ_ERR_MEM, "out of memory");
  for (int i = 0; i < sc->n_materials; ++i) {
    const ej_scene_material *sm = &sc->materials[i];
    ej_model *m = &sim->models[i];
    m->name = sm->name;
    m->rho0 = sm->rho0;
    if (sm->eos_ops) {
      m->eos = ej_calloc(1, sizeof *m->eos);
      EJ_ENSURE(m->eos, EJ_ERR_MEM, "out of memory");
      m->eos->ops = sm->eos_ops;
      m->eos->config = sm->eos_config;
      EJ_TRY(sm->eos_ops->create(sm->eos_config, &m->eos->state));
    }
    if (sm->mat_ops) {
      m->mat = ej_calloc(1, sizeof *m->mat);
      EJ_ENSURE(m->mat, EJ_ERR_MEM, "out of memory");
      m->mat->ops = sm->mat_ops;
      EJ_TRY(sm->mat_ops->create(sm->mat_config, &m->mat->state));
    }
  }
  return EJ_OK;
}

static void ej_models_destroy(ej_sim *sim)
{
  if (!sim->models) return;
  for (int i = 0; i < sim->scene->n_materials; ++i) {
    ej_model *m = &sim->models[i];
    if (m->eos) {
      if (m->eos->state) m->eos->ops->destroy(m->eos->state);
      ej_free(m->eos);
    }
    if (m->mat) {
      if (m->mat->state) m->mat->ops->destroy(m->mat->state);
      ej_free(m->mat);
    }
  }
  ej_free(sim->models);
}

/* Specific energy giving pressure p at density rho (bisection: p(rho, e) increases with e). */
static ej_err ej_eos_invert(const ej_eos *eos, ej_real rho, ej_real p, const ej_loc *loc, ej_real *e)
{
  ej_real lo = 0, hi = 1, plo, phi;
  EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &lo, &plo, NULL));
  if (plo > p) {
    hi = 0;
    lo = -1;
    for (int k = 0; k < 400; ++k) {
      EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &lo, &plo, NULL));
      if (plo <= p) break;
      lo *= 2;
    }
  } else {
    for (int k = 0; k < 400; ++k) {
      EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &hi, &phi, NULL));
      if (phi >= p) break;
      hi *= 2;
    }
  }
  EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &lo, &plo, NULL));
  EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &hi, &phi, NULL));
  if (!(plo <= p && phi >= p))
    return ej_error_input(loc, "no internal energy gives pressure %g Pa at density %g kg/m^3 with this EOS", p, rho);
  for (int k = 0; k < 200 && hi - lo > 1e-15 * fabs(hi); ++k) {
    ej_real mid = 0.5 * (lo + hi), pm;
    EJ_TRY(ej_eos_evaluate(eos, 1, &rho, &mid, &pm, NULL));
    if (pm < p) lo = mid;
    else hi = mid;
  }
  *e = 0.5 * (lo + hi);
  return EJ_OK;
}

/* ------------------------------------------------------------------ sets */

static bool ej_bc_applies(const ej_scene_bc *bc, int set) { return bc->set < 0 || bc->set == set; }

/* A symmetry or periodic boundary that applies to the set: it makes the set's mirror or periodic images. */
static bool ej_bc_images(const ej_scene_bc *bc, int set)
{
  return (bc->kind == EJ_BC_SYMMETRY || bc->kind == EJ_BC_PERIODIC) && ej_bc_applies(bc, set);
}

/* A fix is for ever; a prescribed velocity while t <= until (the time of the configuration whose
 * accelerations are being constrained): after it the particles are free, released at the last
 * step with t <= until. */
static bool ej_bc_active(const ej_sim *sim, const ej_scene_bc *bc)
{
  return bc->kind != EJ_BC_VELOCITY || sim->t <= bc->until + 1e-12 * (sim->scene->t_end > 0 ? sim->scene->t_end : 1);
}

/* Whether an `initial` block applies at x (no region: everywhere). */
static bool ej_init_covers(const ej_scene_init *in, const ej_real *x)
{
  return !in->region || ej_shape_contains(in->region, x);
}

static ej_err ej_set_initial(ej_sim *sim, ej_set *s, const ej_scene_set *ss, const ej_points *pts)
{
  const ej_model *model = s->model;
  ej_real *x = s->fields[s->f_x].data, *v = s->fields[s->f_v].data;
  ej_real *m = s->fields[s->f_m].data, *vol = s->fields[s->f_vol0].data;
  int32_t *id = s->fields[s->f_id].data;
  ej_real *rho = ej_set_field(s, "rho"), *e = ej_set_field(s, "e");
  ej_real *rho_init = ej_malloc((size_t)s->n * sizeof *rho_init);
  ej_err rc = EJ_OK;
  if (!rho_init) {
    rc = ej_error_push(EJ_ERR_MEM, __FILE__, __LINE__, __func__, "out of memory");
    goto out_free;
  }
  s->spacing_min = INFINITY;
  for (ej_idx i = 0; i < s->n; ++i) {
    memcpy(x + 3 * i, pts->x + 3 * i, 3 * sizeof *x);
    vol[i] = pts->vol[i];
    id[i] = i;
    rho_init[i] = model->rho0;
    if (pts->spacing[i] < s->spacing_min) s->spacing_min = pts->spacing[i];
  }
  if (s->f_x0 >= 0) memcpy(s->fields[s->f_x0].data, x, (size_t)s->n * 3 * sizeof *x);
  if (ss->mass > 0) { /* the set's `mass`: one factor on every volume, at the densities set below */
    for (int k = 0; k < ss->n_init; ++k)
      if (ss->init[k].has_rho)
        for (ej_idx i = 0; i < s->n; ++i)
          if (ej_init_covers(&ss->init[k], x + 3 * i)) rho_init[i] = ss->init[k].rho;
    double total = 0;
    for (ej_idx i = 0; i < s->n; ++i) total += (double)rho_init[i] * vol[i];
    const ej_real scale = (ej_real)(ss->mass / total);
    for (ej_idx i = 0; i < s->n; ++i) vol[i] *= scale;
  }
  for (int k = 0; k < ss->n_init; ++k) {
    const ej_scene_init *in = &ss->init[k];
    if ((in->has_e || in->has_p || in->has_energy_total) && !e) {
      rc = ej_error_input(&in->loc, "set '%s': its method has no internal energy to initialise", s->name);
      goto out_free;
    }
    if (in->has_p && !model->eos) {
      rc = ej_error_input(&in->loc, "set '%s': an initial pressure needs an equation of state in material '%s'",
                          s->name, model->name);
      goto out_free;
    }
    ej_real mass_in = 0;
    for (ej_idx i = 0; i < s->n; ++i) {
      if (!ej_init_covers(in, x + 3 * i)) continue;
      if (in->has_rho) rho_init[i] = in->rho;
      if (in->has_v) memcpy(v + 3 * i, in->v, 3 * sizeof *v);
      if (in->has_e) e[i] = in->e;
      if (in->has_p) EJ_TRY_GOTO(rc, ej_eos_invert(model->eos, rho_init[i], in->p, &in->loc, &e[i]), out_free);
      mass_in += rho_init[i] * vol[i];
    }
    if (in->has_energy_total) {
      if (mass_in <= 0) {
        rc = ej_error_input(&in->loc, "set '%s': the energy_total region holds no particle", s->name);
        goto out_free;
      }
      for (ej_idx i = 0; i < s->n; ++i)
        if (ej_init_covers(in, x + 3 * i)) e[i] += in->energy_total / mass_in;
    }
  }
  for (ej_idx i = 0; i < s->n; ++i) {
    m[i] = rho_init[i] * vol[i];
    if (rho) rho[i] = rho_init[i];
  }
  /* Constrained particles are chosen once, in the initial configuration. */
  for (int b = 0; b < sim->scene->n_bcs; ++b) {
    const ej_scene_bc *bc = &sim->scene->bcs[b];
    if ((bc->kind != EJ_BC_FIX && bc->kind != EJ_BC_VELOCITY && bc->kind != EJ_BC_NONREFLECT &&
         bc->kind != EJ_BC_PRESSURE) ||
        !ej_bc_applies(bc, s->index))
      continue;
    for (ej_idx i = 0; i < s->n; ++i)
      if (!bc->region || ej_shape_contains(bc->region, x + 3 * i)) {
        s->bc_mask[i] |= 1u << b;
        for (int c = 0; c < 3; ++c)
          if (bc->comp[c]) v[3 * i + c] = bc->kind == EJ_BC_VELOCITY ? bc->velocity[c] : 0;
      }
  }
out_free:
  ej_free(rho_init);
  return rc;
}

/* What the integrator writes (step_mask) and what each method pass and post_step writes
 * (ej_method_ops.pass_writes, ABI 1.3), for the ghost refresh by need (ej_set_refresh_ghosts). */
static ej_err ej_set_write_masks(ej_set *s)
{
  s->step_mask = (UINT64_C(1) << s->f_x) | (UINT64_C(1) << s->f_v) | (UINT64_C(1) << s->f_a);
  for (int k = 0; k < s->n_fields; ++k)
    if (s->fields[k].rate >= 0 || s->fields[k].rate_of >= 0) s->step_mask |= UINT64_C(1) << k;
  const int bcp[2] = {ej_set_find_field(s, "bc_power"), ej_set_find_field(s, "bc_power_old")};
  for (int k = 0; k < 2; ++k)
    if (bcp[k] >= 0) s->step_mask |= UINT64_C(1) << bcp[k];
  const ej_method_ops *m = s->mops;
  const bool has = EJ_HAS_OP(m, ej_method_ops, pass_writes) && m->pass_writes;
  for (int q = 0; q <= EJ_MAX_PASS_MASKS; ++q) {
    const int pass = q - 1; /* EJ_PASS_POST_STEP, then 0 .. */
    s->pass_mask[q] = EJ_ALL_FIELDS;
    if (!has || pass >= m->n_passes) continue;
    const char *names[EJ_MAX_FIELDS];
    const int nw = m->pass_writes(s->mstate, pass, names, EJ_MAX_FIELDS);
    if (nw < 0) continue;
    EJ_ENSURE(nw <= EJ_MAX_FIELDS, EJ_ERR_PLUGIN, "method '%s': pass_writes returned %d names (max %d)", m->name, nw,
              EJ_MAX_FIELDS);
    uint64_t mask = 0;
    for (int k = 0; k < nw; ++k) {
      const int f = names[k] ? ej_set_find_field(s, names[k]) : -1;
      EJ_ENSURE(f >= 0, EJ_ERR_PLUGIN, "method '%s': pass %d writes field '%s', which set '%s' does not have", m->name,
                pass, names[k] ? names[k] : "(null)", s->name);
      mask |= UINT64_C(1) << f;
    }
    s->pass_mask[q] = mask | s->foreign_mask;
  }
  return EJ_OK;
}

/* Ghost refresh before a pass: only the fields written since the last one; EJECTA_GHOST_CHECK
 * compares the result with a full refresh. */
static ej_err ej_ghosts_refresh(ej_sim *sim, ej_set *s)
{
  ej_set_refresh_ghosts(s, sim->xforms);
  if (!sim->ghost_check) return EJ_OK;
  ej_idx g = -1;
  const int k = ej_set_ghosts_stale(s, sim->xforms, &g);
  EJ_ENSURE(k < 0, EJ_ERR_INTERNAL,
            "ghost refresh: field '%s' of set '%s' is stale at ghost %d (written but not declared by a pass_writes?)",
            s->fields[k].name, s->name, (int)g);
  return EJ_OK;
}

/* After pass (EJ_PASS_POST_STEP for post_step) of s's method. */
static void ej_mark_pass(ej_set *s, int pass)
{
  s->ghost_dirty |= pass + 1 <= EJ_MAX_PASS_MASKS ? s->pass_mask[pass + 1] : EJ_ALL_FIELDS;
}

/* Non-reflecting boundaries on s: the dashpots' impedances (from the scene or from the material's
 * initial moduli, as LS-DYNA's *BOUNDARY_NON_REFLECTING takes them) and the two fields that keep
 * their work exact: nr_force (the dashpot force of the last evaluation) and nr_power. */
static ej_err ej_set_nonreflect(ej_sim *sim, ej_set *s)
{
  const ej_scene *sc = sim->scene;
  bool any = false;
  for (int b = 0; b < sc->n_bcs; ++b) {
    const ej_scene_bc *bc = &sc->bcs[b];
    if (bc->kind != EJ_BC_NONREFLECT || !ej_bc_applies(bc, s->index)) continue;
    any = true;
    const ej_model *md = s->model;
    const ej_real rho0 = md->rho0, rho = isnan(bc->rho) ? rho0 : bc->rho;
    ej_real cp = bc->cp, cs = bc->cs;
    if (!md->mat) { /* a fluid: no shear dashpot unless given */
      if (isnan(cp))
        return ej_error_input(&bc->loc,
                              "non_reflecting on set '%s': material '%s' has no strength model to take the wave "
                              "speed from; give cp (its sound speed)",
                              s->name, md->name);
      if (isnan(cs)) cs = 0;
    }
    if (isnan(cp) || isnan(cs)) {
      ej_real K = 0, G = 0;
      EJ_TRY(ej_material_moduli(md->mat, &K, &G));
      if (isnan(cp)) cp = sqrt((K + 4.0 / 3.0 * G) / rho0);
      if (isnan(cs)) cs = sqrt(G / rho0);
    }
    EJ_ENSURE(isfinite(cp) && isfinite(cs) && cp >= 0 && cs >= 0, EJ_ERR_PLUGIN,
              "set '%s': material '%s' gives wave speeds c_p = %g, c_s = %g m/s for non_reflecting", s->name,
              md->name, cp, cs);
    s->nr_zp[b] = rho * cp;
    s->nr_zs[b] = rho * cs;
    s->nr_bits |= 1u << b;
  }
  if (!any) return EJ_OK;
  static const ej_field_decl f[] = {
      {.name = "nr_force", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "N",
       .doc = "force of the non-reflecting boundaries' dashpots on the particle"},
      {.name = "nr_power", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "W",
       .doc = "nr_force . v at the end of the last step (the next step's work starts from it)"}};
  EJ_TRY(ej_set_add_field(s, &f[0], NULL));
  EJ_TRY(ej_set_add_field(s, &f[1], NULL));
  return EJ_OK;
}

/* Pressure loads on s: the bits, the face's initial positions (load_x0: the load is a function of the
 * face as it was at t = 0) and the two fields that make the load's work exact, as for the dashpots:
 * load_force (the load's force at the last evaluation) and load_power. */
static ej_err ej_set_pressure(ej_sim *sim, ej_set *s)
{
  const ej_scene *sc = sim->scene;
  for (int b = 0; b < sc->n_bcs; ++b)
    if (sc->bcs[b].kind == EJ_BC_PRESSURE && ej_bc_applies(&sc->bcs[b], s->index)) s->pr_bits |= 1u << b;
  if (!s->pr_bits) return EJ_OK;
  static const ej_field_decl f[] = {
      {.name = "load_force", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "N",
       .doc = "force of the pressure loads on the particle"},
      {.name = "load_power", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "W",
       .doc = "load_force . v at the end of the last step (the next step's work starts from it)"},
      {.name = "load_x0", .kind = EJ_VEC3, .flags = EJ_FIELD_NO_GHOST, .unit = "m",
       .doc = "position at t = 0, where the pressure loads are evaluated"},
      {.name = "load_blast", .kind = EJ_TENSOR9, .flags = EJ_FIELD_NO_GHOST, .unit = "1",
       .doc = "the particle's first blast load on its face at t = 0 (ej_blast_pt: arrival, weighted peaks, decays, "
              "durations), kept so that a step evaluates two exponentials instead of the curves"}};
  bool blast = false;
  for (int b = 0; b < sc->n_bcs; ++b) blast |= (s->pr_bits & (1u << b)) && sc->bcs[b].source == EJ_PRESSURE_BLAST;
  _Static_assert(sizeof(ej_blast_pt) <= EJ_TENSOR9 * sizeof(ej_real), "ej_blast_pt fits a tensor9 field");
  for (int k = 0; k < (blast ? 4 : 3); ++k) EJ_TRY(ej_set_add_field(s, &f[k], NULL));
  return EJ_OK;
}

/* The initial positions of a set with pressure loads (load_x0); a blast load's particles must lie
 * where the Kingery-Bulmash curves are fitted, and a pressure region must hold particles. */
static ej_err ej_set_pressure_init(const ej_sim *sim, ej_set *s)
{
  const ej_real *x = s->fields[s->f_x].data;
  ej_real *x0 = ej_set_field(s, "load_x0"), *kept = ej_set_field(s, "load_blast");
  if (x0) memcpy(x0, x, (size_t)s->n * 3 * sizeof *x0);
  for (ej_idx i = 0; kept && i < s->n; ++i) { /* the particle's first blast load, as ej_pressure_apply takes it */
    uint32_t mask = s->bc_mask[i] & s->pr_bits;
    for (int b = 0; mask; ++b, mask >>= 1) {
      const ej_scene_bc *bc = &sim->scene->bcs[b];
      ej_real n[3];
      if (!(mask & 1u) || bc->source != EJ_PRESSURE_BLAST) continue;
      ej_blast_pt bp = {.t0 = INFINITY}; /* a particle at a radial face's centre: no load */
      if (ej_bc_face_normal(bc, x + 3 * i, n)) ej_blast_point(bc->burst, bc->tnt, bc->charge, bc->t_det, x + 3 * i, n, &bp);
      memcpy(kept + EJ_TENSOR9 * i, &bp, sizeof bp);
      break;
    }
  }
  for (int b = 0; b < sim->scene->n_bcs; ++b) {
    if (!(s->pr_bits & (1u << b))) continue;
    const ej_scene_bc *bc = &sim->scene->bcs[b];
    ej_idx n = 0;
    for (ej_idx i = 0; i < s->n; ++i) {
      if (!(s->bc_mask[i] & (1u << b))) continue;
      ++n;
      if (bc->source != EJ_PRESSURE_BLAST) continue;
      const ej_real *xi = x + 3 * i, w3 = cbrt(bc->tnt);
      const ej_real R = sqrt((xi[0] - bc->charge[0]) * (xi[0] - bc->charge[0]) +
                             (xi[1] - bc->charge[1]) * (xi[1] - bc->charge[1]) +
                             (xi[2] - bc->charge[2]) * (xi[2] - bc->charge[2]));
      ej_real zmin, zmax;
      ej_blast_range(bc->burst, &zmin, &zmax);
      if (!(R / w3 >= zmin && R / w3 <= zmax))
        return ej_error_input(&bc->loc,
                              "pressure blast on set '%s': the particle at (%g, %g, %g) m is %g m from the charge, "
                              "scaled distance Z = %g m/kg^(1/3); the Kingery-Bulmash curves hold for %g <= Z <= %g "
                              "(%g to %g m for %g kg)",
                              s->name, xi[0], xi[1], xi[2], R, R / w3, zmin, zmax, zmin * w3, zmax * w3, bc->tnt);
    }
    if (n == 0)
      return ej_error_input(&bc->loc, "pressure on set '%s': its region holds no particle of the set", s->name);
  }
  return EJ_OK;
}

static ej_err ej_sets_create(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  sim->sets = ej_calloc((size_t)sc->n_sets, sizeof *sim->sets);
  EJ_ENSURE(sim->sets, EJ_ERR_MEM, "out of memory");
  for (int i = 0; i < sc->n_sets; ++i) {
    const ej_scene_set *ss = &sc->sets[i];
    ej_set *s;
    EJ_TRY(ej_set_create(ss->name, i, sc->dimension, &s));
    sim->sets[sim->n_sets++] = s;
    s->mops = ss->method_ops;
    s->mconfig = ss->method_config;
    s->model = &sim->models[ss->material];
    s->t = &sim->t;
    s->sim = sim;
    s->dt = &sim->dt;
    ej_decl d = {.set = s};
    EJ_TRY(s->mops->declare(s->mconfig, sc->dimension, &d));
    const ej_eos *eos = s->model->eos;
    if (eos && EJ_HAS_OP(eos->ops, ej_eos_ops, declare)) {
      const ej_nbr_config keep = s->nbr_config; /* an EOS declares fields, never neighbours */
      ej_decl de = {.set = s};
      EJ_TRY(eos->ops->declare(eos->config, sc->dimension, &de));
      s->nbr_config = keep;
      s->foreign_mask |= de.touched; /* written by the EOS inside any method pass */
    }
    /* Prescribed velocities do work: its power is kept per particle (now and a step ago) for
     * the trapezoidal external work of the energy budget; checkpointed like any field. */
    for (int b = 0; b < sc->n_bcs; ++b)
      if (sc->bcs[b].kind == EJ_BC_VELOCITY && ej_bc_applies(&sc->bcs[b], i)) {
        static const ej_field_decl pw[] = {
            {.name = "bc_power", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "W",
             .doc = "power of the prescribed-velocity constraint on the particle"},
            {.name = "bc_power_old", .kind = EJ_SCALAR, .flags = EJ_FIELD_NO_GHOST, .unit = "W",
             .doc = "bc_power one step earlier"}};
        EJ_TRY(ej_set_add_field(s, &pw[0], NULL));
        EJ_TRY(ej_set_add_field(s, &pw[1], NULL));
        break;
      }
    EJ_TRY(ej_set_nonreflect(sim, s));
    EJ_TRY(ej_set_pressure(sim, s));
    const ej_material *mat = s->model->mat;
    for (int k = 0; mat && k < mat->ops->n_hist; ++k) {
      /* A history variable named like a field the method or EOS declared (tlpd's "damage", the
       * broken-bond fraction, against the "damage" of johnson_cook, dp_damage or jh2) would share
       * that field, and the two writers would overwrite each other: it is named mat_<name>
       * instead. The material reads its history through ej_set_hist, not by name. */
      char hname[EJ_FIELD_NAME_LEN];
      const char *hn = mat->ops->hist_names[k];
      if (ej_set_find_field(s, hn) >= 0) {
        const int len = snprintf(hname, sizeof hname, "mat_%s", hn);
        EJ_ENSURE(len < (int)sizeof hname && ej_set_find_field(s, hname) < 0, EJ_ERR_PLUGIN,
                  "set '%s': history variable '%s' of material model '%s' clashes with a field of the method", s->name,
                  hn, mat->ops->name);
        hn = hname;
      }
      const ej_field_decl hd = {.name = hn, .kind = EJ_SCALAR, .flags = EJ_FIELD_OUTPUT, .unit = "1",
                                .doc = "history variable of the strength model"};
      EJ_TRY(ej_set_add_field(s, &hd, &s->f_hist[k]));
      s->n_hist = k + 1;
      s->foreign_mask |= UINT64_C(1) << s->f_hist[k]; /* written by the strength model */
    }
    if (s->nbr_config == EJ_NBR_REFERENCE) {
      static const ej_field_decl x0 = {.name = "x0", .kind = EJ_VEC3, .flags = EJ_FIELD_POSITION, .unit = "m",
                                       .doc = "reference position"};
      EJ_TRY(ej_set_add_field(s, &x0, NULL));
    }
    ej_points pts = {0};
    EJ_TRY(ej_scene_set_points(sc, i, &pts));
    s->n = pts.n;
    ej_err rc = ej_set_reserve(s, pts.n + pts.n / 16 + 64); /* ghosts grow it on demand */
    if (rc == EJ_OK) rc = ej_set_initial(sim, s, ss, &pts);
    ej_points_free(&pts);
    EJ_TRY(rc);
    EJ_TRY(ej_set_pressure_init(sim, s));
    if (s->n_hist > 0 && mat->ops->init_hist) {
      ej_real *hist[EJ_MAX_HIST];
      ej_set_hist(s, hist, EJ_MAX_HIST);
      EJ_TRY(mat->ops->init_hist(mat->state, s->n, hist));
    }
    if (eos && EJ_HAS_OP(eos->ops, ej_eos_ops, setup)) EJ_TRY(eos->ops->setup(eos->state, s));
    EJ_TRY(ej_located(s->mops->create(s->mconfig, s, s->model, &s->mstate), &ss->loc));
    if (s->nbr_config != EJ_NBR_NONE) EJ_TRY(ej_nbrlist_create(&s->list));
    EJ_TRY(ej_set_write_masks(s));
  }
  return EJ_OK;
}

/* Every method's setup (serial), on the sets' initial state. A refusal of the input (a rigid body
 * whose points lie on a line, a tlpd initial_stress row missing, a particle without mass) is tied to
 * the set's place in the scene, as create's are; `ejecta check` runs it too. */
static ej_err ej_sets_setup(ej_sim *sim)
{
  for (int i = 0; i < sim->n_sets; ++i)
    if (sim->sets[i]->mops->setup)
      EJ_TRY(ej_located(sim->sets[i]->mops->setup(sim->sets[i]->mstate, sim->sets[i]), &sim->scene->sets[i].loc));
  return EJ_OK;
}

static ej_err ej_check_output_fields(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  for (int f = 0; f < sc->n_output_fields; ++f) {
    bool found = false;
    const char *cands[EJ_MAX_FIELDS * 4];
    int nc = 0;
    for (int i = 0; i < sim->n_sets; ++i) {
      found |= ej_set_find_field(sim->sets[i], sc->output_fields[f]) >= 0;
      for (int k = 0; k < sim->sets[i]->n_fields && nc < EJ_MAX_FIELDS * 4; ++k)
        cands[nc++] = sim->sets[i]->fields[k].name;
    }
    if (!found) {
      const char *near = ej_nearest_word(sc->output_fields[f], cands, nc);
      if (near)
        return ej_error_input(&sc->output_field_locs[f], "unknown output field '%s'; did you mean '%s'?",
                              sc->output_fields[f], near);
      return ej_error_input(&sc->output_field_locs[f], "unknown output field '%s' (no set has it)",
                            sc->output_fields[f]);
    }
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ ghosts and rebuilds */

static int ej_xform_index(ej_sim *sim, const ej_xform *t)
{
  for (int k = 0; k < sim->n_xforms; ++k)
    if (!memcmp(&sim->xforms[k], t, sizeof *t)) return k;
  if (sim->n_xforms == EJ_MAX_XFORMS) return -1;
  sim->xforms[sim->n_xforms] = *t;
  return sim->n_xforms++;
}

/* c = a after b: x -> Qa (Qb x + bb) + ba */
static void ej_xform_compose(const ej_xform *a, const ej_xform *b, ej_xform *c)
{
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j)
      c->Q[3 * i + j] = a->Q[3 * i] * b->Q[j] + a->Q[3 * i + 1] * b->Q[3 + j] + a->Q[3 * i + 2] * b->Q[6 + j];
    c->b[i] = a->Q[3 * i] * b->b[0] + a->Q[3 * i + 1] * b->b[1] + a->Q[3 * i + 2] * b->b[2] + a->b[i];
  }
}

/* memo: the index of t for this (plane or shift, source transform), -1 until first found; the
 * composed transform depends on these only, so the index found is the same as a fresh search's */
static ej_err ej_ghost_push(ej_sim *sim, ej_set *s, ej_idx src, const ej_xform *t, int16_t *memo)
{
  int k = *memo >= 0 ? *memo : ej_xform_index(sim, t);
  *memo = (int16_t)k;
  EJ_ENSURE(k >= 0, EJ_ERR_UNSUPPORTED, "too many distinct ghost transforms (more than %d)", EJ_MAX_XFORMS);
  /* grow by half: every field of the set is reallocated, so doubling would waste memory */
  if (s->n + s->n_ghost >= s->cap) EJ_TRY(ej_set_reserve(s, s->cap + s->cap / 2 + 64));
  s->ghost_src[s->n_ghost] = src;
  s->ghost_xf[s->n_ghost] = (uint8_t)k;
  s->n_ghost++;
  return EJ_OK;
}

/* Ghost images of particles within cutoff of each symmetry plane and periodic face, built
 * from the positions at the last rebuild (x_build) so that a restart rebuilds the same. */
static ej_err ej_ghosts_build(ej_sim *sim, ej_set *s, int f_pos, ej_real cutoff)
{
  const ej_scene *sc = sim->scene;
  /* neighbours.ghost_reach: the smallest layer of every set (its partners' rows may need more) */
  if (cutoff < sc->ghost_reach) cutoff = sc->ghost_reach;
  s->n_ghost = 0;
  enum { EJ_MEMO_K = 4 };
  int16_t memo[EJ_MAX_XFORMS + 1][2][EJ_MEMO_K]; /* [source transform][side][period - 1] */
  for (int b = 0; b < sc->n_bcs; ++b) {
    const ej_scene_bc *bc = &sc->bcs[b];
    if (!ej_bc_images(bc, s->index)) continue;
    memset(memo, 0xff, sizeof memo); /* -1 */
    const ej_idx n_images = s->n + s->n_ghost; /* images of images give edges and corners */
    for (ej_idx g = 0; g < n_images; ++g) {
      /* re-read: pushing a ghost may grow (reallocate) every field */
      const ej_real *xb = s->fields[f_pos].data;
      ej_idx src = g < s->n ? g : s->ghost_src[g - s->n];
      const ej_xform *cur = &sim->xforms[g < s->n ? 0 : s->ghost_xf[g - s->n]];
      ej_real y[3];
      for (int r = 0; r < 3; ++r)
        y[r] = cur->Q[3 * r] * xb[3 * src] + cur->Q[3 * r + 1] * xb[3 * src + 1] + cur->Q[3 * r + 2] * xb[3 * src + 2] +
               cur->b[r];
      if (bc->kind == EJ_BC_SYMMETRY) {
        const ej_real *nn = bc->normal, *p0 = bc->point;
        ej_real d = (y[0] - p0[0]) * nn[0] + (y[1] - p0[1]) * nn[1] + (y[2] - p0[2]) * nn[2];
        if (d < 0 || d >= cutoff) continue;
        ej_xform mirror = {.Q = {0}};
        ej_real pn = p0[0] * nn[0] + p0[1] * nn[1] + p0[2] * nn[2];
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) mirror.Q[3 * i + j] = (i == j) - 2 * nn[i] * nn[j];
          mirror.b[i] = 2 * pn * nn[i];
        }
        ej_xform t;
        const int ci = g < s->n ? 0 : s->ghost_xf[g - s->n];
        if (memo[ci][0][0] < 0) ej_xform_compose(&mirror, cur, &t);
        EJ_TRY(ej_ghost_push(sim, s, src, &t, &memo[ci][0][0]));
      } else {
        /* As many periods as the search radius spans (a thin periodic slab). */
        const ej_real L = bc->hi - bc->lo;
        const int kmax = (int)ceil(cutoff / L);
        for (int side = 0; side < 2; ++side)
          for (int k = 1; k <= kmax; ++k) {
          const ej_real reach = cutoff - (k - 1) * L;
          bool near = side == 0 ? y[bc->axis] - bc->lo < reach : bc->hi - y[bc->axis] <= reach;
          if (!near) continue;
          ej_xform shift = {.Q = {1, 0, 0, 0, 1, 0, 0, 0, 1}};
          shift.b[bc->axis] = side == 0 ? k * L : -k * L;
          ej_xform t;
          const int ci = g < s->n ? 0 : s->ghost_xf[g - s->n];
          int16_t none = -1, *mk = k <= EJ_MEMO_K ? &memo[ci][side][k - 1] : &none;
          if (*mk < 0) ej_xform_compose(&shift, cur, &t);
          EJ_TRY(ej_ghost_push(sim, s, src, &t, mk));
        }
      }
    }
  }
  return EJ_OK;
}

/* Positions and radii of owned + ghost particles at the last rebuild, for the list build. */
static ej_err ej_build_points(ej_sim *sim, ej_set *s, int f_pos, ej_real **xs, ej_real **rs)
{
  const ej_idx nt = s->n + s->n_ghost;
  ej_real *x = ej_malloc((size_t)nt * 3 * sizeof *x), *r = ej_malloc((size_t)nt * sizeof *r);
  if (!x || !r) {
    ej_free(x);
    ej_free(r);
    EJ_FAIL(EJ_ERR_MEM, "out of memory");
  }
  const ej_real *xb = s->fields[f_pos].data, *rb = s->fields[s->f_rb].data;
  memcpy(x, xb, (size_t)s->n * 3 * sizeof *x);
  memcpy(r, rb, (size_t)s->n * sizeof *r);
#pragma omp parallel for schedule(static) if (s->n_ghost > 4096)
  for (ej_idx g = 0; g < s->n_ghost; ++g) {
    const ej_xform *t = &sim->xforms[s->ghost_xf[g]];
    const ej_real *p = xb + 3 * s->ghost_src[g];
    for (int k = 0; k < 3; ++k)
      x[3 * (s->n + g) + k] = t->Q[3 * k] * p[0] + t->Q[3 * k + 1] * p[1] + t->Q[3 * k + 2] * p[2] + t->b[k];
    r[s->n + g] = rb[s->ghost_src[g]];
  }
  *xs = x;
  *rs = r;
  return EJ_OK;
}

static ej_err ej_support_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)ctx, (void)c;
  return s->mops->support(s->mstate, s, r, s->radius + r.begin);
}

static ej_real ej_set_rmax(const ej_set *s, const ej_real *r)
{
  ej_real m = 0;
  for (ej_idx i = 0; i < s->n; ++i) m = r[i] > m ? r[i] : m;
  return m;
}

/* Search radii of a build scaled by 1 + skin (the per-particle Verlet skin s_i = skin R_i): the
 * lists are then built with no absolute skin. */
static void ej_skin_radii(ej_real *r, ej_idx n, ej_real skin)
{
  const ej_real f = 1 + skin;
  for (ej_idx i = 0; i < n; ++i) r[i] *= f;
}

/* The largest build radius of the sets that s has a two-set interaction with (0 if none). */
static ej_real ej_partner_rmax(const ej_sim *sim, const ej_set *s)
{
  ej_real r = 0;
  for (int k = 0; k < sim->n_inter; ++k) {
    const ej_inter *in = &sim->inter[k];
    if (!in->b || (in->a != s && in->b != s)) continue;
    const ej_set *o = in->a == s ? in->b : in->a;
    const ej_real m = ej_set_rmax(o, o->fields[o->f_rb].data);
    r = m > r ? m : r;
  }
  return r;
}

/* Ghosts and lists from x_build / r_build (shared by a rebuild and a restart). */
static ej_err ej_lists_from_build(ej_sim *sim)
{
  const ej_real skin = sim->scene->skin;
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    if (s->nbr_config == EJ_NBR_REFERENCE && !s->list->pub.off) {
      /* Fixed families: built once in the reference configuration, never rebuilt (bond
       * state stored by the method stays aligned with the CSR entries). Mirror and periodic
       * ghosts are made once too, from the reference positions (x_build = x0 at t = 0). The
       * search radii are those of the build (a restart has not computed them: the probes' gauge
       * weights read them, and the skin watch refreshes them only for sets an interaction
       * searches). */
      memcpy(s->radius, s->fields[s->f_rb].data, (size_t)s->n * sizeof(ej_real));
      const ej_real rmax = ej_set_rmax(s, s->fields[s->f_rb].data);
      EJ_TRY(ej_ghosts_build(sim, s, s->f_x0, rmax));
      ej_real *xs, *rs;
      EJ_TRY(ej_build_points(sim, s, s->f_x0, &xs, &rs));
      ej_err rc = ej_nbrlist_build(s->list, s->dim, xs, rs, s->n, xs, rs, s->n + s->n_ghost, 0, true);
      ej_free(xs);
      ej_free(rs);
      EJ_TRY(rc);
      const ej_off nb = s->list->pub.off[s->n];
      if (s->bond_flags) { /* restored from a checkpoint: the family is rebuilt identically */
        EJ_ENSURE(s->n_bonds == nb, EJ_ERR_INPUT, "set '%s': the checkpoint has %lld bonds, the rebuilt family %lld",
                  s->name, (long long)s->n_bonds, (long long)nb);
      } else {
        s->bond_flags = ej_calloc((size_t)nb + 1, 1);
        EJ_ENSURE(s->bond_flags, EJ_ERR_MEM, "out of memory");
        s->n_bonds = nb;
      }
      continue;
    }
    if (s->nbr_config == EJ_NBR_NONE && !s->in_interaction && s->n > 0 && s->mops->support) {
      /* no list and no skin watch: the radii only for a probe's gauge weights (after a restart too) */
      EJ_TRY(ej_for_chunks(sim, s, ej_support_chunk, NULL));
      continue;
    }
    if (s->nbr_config == EJ_NBR_NONE && s->wants_images && s->n > 0) {
      /* no list of its own, but an interaction that needs its images (ABI 1.9 needs_images: kernel_contact
       * with a rigid_body without normals), as far as the partners' rows reach */
      const ej_real rmax = ej_set_rmax(s, s->fields[s->f_rb].data), reach = ej_partner_rmax(sim, s);
      EJ_TRY(ej_ghosts_build(sim, s, s->f_xb, (rmax > reach ? rmax : reach) * (1 + skin)));
      continue;
    }
    if (s->nbr_config != EJ_NBR_CURRENT) continue;
    ej_real rmax = ej_set_rmax(s, s->fields[s->f_rb].data);
    /* the ghosts are also the candidates of the rows of s's interaction partners, whose reach
     * (1 + skin) max(R_i, R_j) may be the partner's larger radius */
    const ej_real reach = ej_partner_rmax(sim, s);
    EJ_TRY(ej_ghosts_build(sim, s, s->f_xb, (rmax > reach ? rmax : reach) * (1 + skin)));
    ej_real *xs, *rs;
    EJ_TRY(ej_build_points(sim, s, s->f_xb, &xs, &rs));
    /* per-particle skin (docs/core.md "Neighbours, ghosts, rebuilds"): pair listed iff
     * |x_ij| < (1 + skin) max(R_i, R_j) at the build */
    ej_skin_radii(rs, s->n + s->n_ghost, skin);
    ej_err rc = ej_nbrlist_build(s->list, s->dim, xs, rs, s->n, xs, rs, s->n + s->n_ghost, 0, true);
    ej_free(xs);
    ej_free(rs);
    EJ_TRY(rc);
    s->list_builds++;
  }
  for (int k = 0; k < sim->n_inter; ++k) {
    ej_inter *in = &sim->inter[k];
    if (!in->b) continue;
    ej_real *xa, *rra, *xb, *rrb;
    EJ_TRY(ej_build_points(sim, in->a, in->a->f_xb, &xa, &rra));
    ej_err rc = ej_build_points(sim, in->b, in->b->f_xb, &xb, &rrb);
    if (rc == EJ_OK) {
      /* per-particle skin, as the sets' own lists: |x_ij| < (1 + skin) max(R_i, R_j) */
      ej_skin_radii(rra, in->a->n + in->a->n_ghost, skin);
      ej_skin_radii(rrb, in->b->n + in->b->n_ghost, skin);
      rc = ej_nbrlist_build(in->list, sim->dim, xa, rra, in->a->n, xb, rrb, in->b->n + in->b->n_ghost, 0, false);
      if (rc == EJ_OK && in->list_ba)
        rc = ej_nbrlist_build(in->list_ba, sim->dim, xb, rrb, in->b->n, xa, rra, in->a->n + in->a->n_ghost, 0, false);
      ej_free(xb);
      ej_free(rrb);
    }
    ej_free(xa);
    ej_free(rra);
    EJ_TRY(rc);
  }
  for (int i = 0; i < sim->n_sets; ++i) ej_set_update_ghosts(sim->sets[i], sim->xforms);
  return EJ_OK;
}

/* Wraps periodic coordinates, sorts particles in cell order, records x_build / r_build. */
static ej_err ej_rebuild(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    ej_real *x = s->fields[s->f_x].data;
    for (int b = 0; b < sc->n_bcs; ++b) {
      const ej_scene_bc *bc = &sc->bcs[b];
      /* reference families keep their bond vectors: their particles are never wrapped */
      if (bc->kind != EJ_BC_PERIODIC || !ej_bc_applies(bc, i) || s->nbr_config == EJ_NBR_REFERENCE) continue;
      const ej_real L = bc->hi - bc->lo;
#pragma omp parallel for schedule(static) if (s->n > 4096)
      for (ej_idx p = 0; p < s->n; ++p) {
        ej_real *y = &x[3 * p + bc->axis];
        if (*y < bc->lo || *y >= bc->hi) *y -= L * floor((*y - bc->lo) / L);
        if (*y >= bc->hi) *y = bc->lo; /* round-off at the upper face */
      }
    }
    if ((s->nbr_config == EJ_NBR_NONE && !s->in_interaction) || s->n == 0) continue;
    /* Reference sets are sorted once, before their families exist. */
    if (s->nbr_config != EJ_NBR_REFERENCE || sim->n_rebuilds == 0) {
      EJ_TRY(ej_for_chunks(sim, s, ej_support_chunk, NULL));
      /* the cells of the list's most populous radius class (its rows then come out ascending) */
      ej_real cell = ej_nbr_sort_cell(s->radius, s->n, 1 + sc->skin);
      ej_idx *perm = ej_malloc((size_t)s->n * sizeof *perm);
      EJ_ENSURE(perm, EJ_ERR_MEM, "out of memory");
      ej_err rc = ej_nbr_sort_order(s->dim, x, s->n, cell, perm);
      if (rc == EJ_OK) rc = ej_set_permute(s, perm);
      ej_free(perm);
      EJ_TRY(rc);
      EJ_TRY(ej_for_chunks(sim, s, ej_support_chunk, NULL));
      memcpy(s->fields[s->f_rb].data, s->radius, (size_t)s->n * sizeof(ej_real));
    }
    memcpy(s->fields[s->f_xb].data, x, (size_t)s->n * 3 * sizeof(ej_real));
  }
  sim->n_rebuilds++;
  return ej_lists_from_build(sim);
}

/* Search radii of a chunk and its part of the skin watch: max_p d_p and max_p e_p with
 * d_p = |x_p - x_build,p|, e_p = (R_p - R_build,p) + d_p - skin R_build,p (maxima: the same whatever
 * the chunking or thread count). */
static ej_err ej_due_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  if (s->nbr_config != EJ_NBR_REFERENCE) EJ_TRY(s->mops->support(s->mstate, s, r, s->radius + r.begin));
  else memcpy(s->radius + r.begin, (const ej_real *)s->fields[s->f_rb].data + r.begin,
              (size_t)(r.end - r.begin) * sizeof(ej_real));
  const ej_real *x = s->fields[s->f_x].data, *xb = s->fields[s->f_xb].data, *rb = s->fields[s->f_rb].data;
  const ej_real *R = s->radius, skin = sim->scene->skin;
  ej_real dmax = 0, emax = -HUGE_VAL;
  for (ej_idx p = r.begin; p < r.end; ++p) {
    const ej_real dx = x[3 * p] - xb[3 * p], dy = x[3 * p + 1] - xb[3 * p + 1], dz = x[3 * p + 2] - xb[3 * p + 2];
    const ej_real d = sqrt(dx * dx + dy * dy + dz * dz);
    const ej_real e = (R[p] - rb[p]) + d - skin * rb[p];
    dmax = d > dmax ? d : dmax;
    emax = e > emax ? e : emax;
  }
  ej_real *cs = sim->chunk_scratch + c * EJ_NSLOT;
  cs[0] = dmax, cs[1] = emax;
  return EJ_OK;
}

/* Whether the step's skin watch covers s: sets searched in the current configuration and sets
 * an interaction searches. */
static bool ej_due_watched(const ej_set *s) { return s->nbr_config == EJ_NBR_CURRENT || s->in_interaction; }

/* The set's skin watch from its chunk maxima of ej_due_chunk (run in the kick-drift region of the
 * step, ej_kick_drift_chunk): s->due_d = max_p d_p, s->due_e = max_p e_p. Returns whether s's own
 * list is due (docs/core.md "Neighbours, ghosts, rebuilds"). A pair is listed iff
 * |x_ij| < (1 + skin) max(R_i, R_j) at the build; one now inside max(R_i, R_j) (say R_i >= R_j)
 * was at the build closer than R_i + d_i + d_j, which the list covers while
 * (R_i - R_build,i) + d_i - skin R_build,i + max_j d_j <= 0, i.e. while due_e + due_d <= 0.
 * Between two sets a and b: while e_a + d_b <= 0 and e_b + d_a <= 0 (ej_due_pairs). */
static bool ej_due_reduce(const ej_sim *sim, ej_set *s)
{
  ej_real dmax = 0, emax = -HUGE_VAL;
  const int64_t nch = ej_chunk_count(s);
  for (int64_t c = 0; c < nch; ++c) {
    const ej_real *cs = sim->chunk_scratch + c * EJ_NSLOT;
    dmax = cs[0] > dmax ? cs[0] : dmax;
    emax = cs[1] > emax ? cs[1] : emax;
  }
  s->due_d = dmax, s->due_e = emax;
  return s->nbr_config == EJ_NBR_CURRENT && emax + dmax > 0;
}

/* Whether a two-set interaction's lists are due (after ej_due_reduce of both sets). */
static bool ej_due_pairs(const ej_sim *sim)
{
  for (int k = 0; k < sim->n_inter; ++k) {
    const ej_inter *in = &sim->inter[k];
    if (in->b && (in->a->due_e + in->b->due_d > 0 || in->b->due_e + in->a->due_d > 0)) return true;
  }
  return false;
}

/* ------------------------------------------------------------------ forces */

typedef struct ej_pass_ctx {
  int pass;
} ej_pass_ctx;

static ej_err ej_compute_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)c;
  const ej_pass_ctx *pc = ctx;
  return s->mops->compute(s->mstate, s, s->list ? &s->list->pub : NULL, pc->pass, r);
}

typedef struct ej_inter_ctx {
  ej_inter *in;
  int pass;
  bool reverse; /* b's side of a both_ways interaction */
} ej_inter_ctx;

static ej_err ej_finish_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)ctx, (void)c;
  return s->mops->finish(s->mstate, s, r);
}

static ej_err ej_inter_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)s, (void)c;
  ej_inter_ctx *ic = ctx;
  ej_inter *in = ic->in;
  if (ic->reverse) return in->ops->compute(in->state, in->b, in->a, &in->list_ba->pub, ic->pass, r);
  return in->ops->compute(in->state, in->a, in->b, in->list ? &in->list->pub : NULL, ic->pass, r);
}

static int ej_inter_passes(const ej_inter *in)
{
  return EJ_HAS_OP(in->ops, ej_interaction_ops, n_passes) && in->ops->n_passes > 1 ? in->ops->n_passes : 1;
}

static ej_err ej_zero_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)ctx, (void)c;
  for (int k = 0; k < s->n_fields; ++k) {
    ej_field *f = &s->fields[k];
    if (k == s->f_a || f->rate_of >= 0)
      memset((ej_real *)f->data + (size_t)r.begin * f->ncomp, 0, (size_t)(r.end - r.begin) * f->ncomp * sizeof(ej_real));
  }
  return EJ_OK;
}

bool ej_bc_face_normal(const ej_scene_bc *bc, const ej_real x[3], ej_real n[3])
{
  for (int k = 0; k < 3; ++k) n[k] = bc->normal[k];
  if (!bc->radial) return true;
  ej_real len = 0;
  for (int k = 0; k < 3; ++k) n[k] = x[k] - bc->point[k], len += n[k] * n[k];
  len = sqrt(len);
  if (!(len > 0)) return false; /* a particle at the centre has no normal */
  for (int k = 0; k < 3; ++k) n[k] = bc->cavity ? -(n[k] / len) : n[k] / len;
  return true;
}

/* The dashpots of the non-reflecting boundaries on particle i (Lysmer & Kuhlemeyer 1969: the traction
 * -rho c_p v_n n - rho c_s v_t on the particle's share of the boundary, A = vol0^((d-1)/d)) as the
 * symmetric matrix K of F = -K v (row-major 3 x 3), summed over the boundaries in mask; n is the
 * outward normal, given or radial from the centre at the particle's current position. */
static void ej_nonreflect_matrix(const ej_sim *sim, const ej_set *s, ej_idx i, uint32_t mask, ej_real K[9])
{
  const ej_real *x = s->fields[s->f_x].data;
  const ej_real area = ej_face_area(sim->scene->dimension, ((const ej_real *)s->fields[s->f_vol0].data)[i]);
  for (int k = 0; k < 9; ++k) K[k] = 0;
  for (int b = 0; mask; ++b, mask >>= 1) {
    if (!(mask & 1u)) continue;
    const ej_scene_bc *bc = &sim->scene->bcs[b];
    ej_real n[3];
    if (!ej_bc_face_normal(bc, x + 3 * i, n)) continue;
    const ej_real zp = s->nr_zp[b] * area, zs = s->nr_zs[b] * area;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) K[3 * r + c] += (zp - zs) * n[r] * n[c] + (r == c ? zs : 0);
  }
}

/* The components of particle i held by an active fix or prescribed velocity. */
static void ej_bc_fixed(const ej_sim *sim, const ej_set *s, ej_idx i, bool fixed[3])
{
  fixed[0] = fixed[1] = fixed[2] = false;
  uint32_t mask = s->bc_mask[i];
  for (int b = 0; mask; ++b, mask >>= 1)
    if (mask & 1u)
      if (ej_bc_active(sim, &sim->scene->bcs[b]))
        for (int k = 0; k < 3; ++k) fixed[k] |= sim->scene->bcs[b].comp[k];
}

/* ABI 1.12 (plugin.h): the components an active fix or prescribed velocity holds, as bits. */
unsigned ej_set_held(const ej_set *s, ej_idx i)
{
  if (!s->sim || !s->bc_mask || i < 0 || i >= s->n) return 0;
  bool fixed[3];
  ej_bc_fixed(s->sim, s, i, fixed);
  return (fixed[0] ? 1u : 0u) | (fixed[1] ? 2u : 0u) | (fixed[2] ? 4u : 0u);
}

/* ABI 1.12: a ghost's owned source and the vector part of its (composed) transform. */
ej_idx ej_set_image_source(const ej_set *s, ej_idx j, ej_real Q[9])
{
  const bool ghost = s->sim && j >= s->n && j < s->n + s->n_ghost;
  const ej_real *q = ghost ? s->sim->xforms[s->ghost_xf[j - s->n]].Q : NULL;
  for (int k = 0; k < 9; ++k) Q[k] = q ? q[k] : (k % 4 == 0 ? 1.0 : 0.0);
  return ghost ? s->ghost_src[j - s->n] : j;
}

/* F = -K w (zero in the held components) into f, and F / m added to a. */
static void ej_nonreflect_apply(const ej_real K[9], const bool fixed[3], const ej_real w[3], ej_real m, ej_real f[3],
                                ej_real a[3])
{
  for (int r = 0; r < 3; ++r) {
    f[r] = fixed[r] ? 0 : -(K[3 * r] * w[0] + K[3 * r + 1] * w[1] + K[3 * r + 2] * w[2]);
    a[r] += f[r] / m;
  }
}

/* The dashpots in the second half kick, implicitly: (m I + dt/2 K) v_n+1 = m (v_half + dt/2 a), a the
 * other forces' acceleration (components held by a constraint keep theirs). With the first half
 * kick's explicit F_n this is the trapezoidal rule for the dashpots, stable for any c dt / dx, so
 * an edge or corner particle under two or three boundaries does not shorten the step. F_n+1 = -K
 * v_n+1 (zero in the held components) goes into a and nr_force. */
static void ej_nonreflect_kick(const ej_sim *sim, ej_set *s, ej_idx i, ej_real h, ej_real *nrf)
{
  ej_real K[9], M[9], rhs[3];
  ej_real *v = (ej_real *)s->fields[s->f_v].data + 3 * i, *a = (ej_real *)s->fields[s->f_a].data + 3 * i;
  const ej_real m = ((const ej_real *)s->fields[s->f_m].data)[i];
  bool fixed[3];
  ej_nonreflect_matrix(sim, s, i, s->bc_mask[i] & s->nr_bits, K);
  ej_bc_fixed(sim, s, i, fixed);
  for (int r = 0; r < 3; ++r) {
    rhs[r] = m * v[r]; /* v = v_half + dt/2 a already */
    for (int c = 0; c < 3; ++c) M[3 * r + c] = fixed[r] ? (r == c ? m : 0) : (r == c ? m : 0) + h * K[3 * r + c];
  }
  /* M is symmetric positive definite, or that with the held rows replaced by m e_r: the adjugate */
  const ej_real adj[9] = {M[4] * M[8] - M[5] * M[7], M[2] * M[7] - M[1] * M[8], M[1] * M[5] - M[2] * M[4],
                          M[5] * M[6] - M[3] * M[8], M[0] * M[8] - M[2] * M[6], M[2] * M[3] - M[0] * M[5],
                          M[3] * M[7] - M[4] * M[6], M[1] * M[6] - M[0] * M[7], M[0] * M[4] - M[1] * M[3]};
  const ej_real det = M[0] * adj[0] + M[1] * adj[3] + M[2] * adj[6];
  ej_real w[3];
  for (int r = 0; r < 3; ++r) w[r] = (adj[3 * r] * rhs[0] + adj[3 * r + 1] * rhs[1] + adj[3 * r + 2] * rhs[2]) / det;
  ej_nonreflect_apply(K, fixed, w, m, nrf + 3 * i, a);
  for (int r = 0; r < 3; ++r)
    if (!fixed[r]) v[r] = w[r];
}

/* The work of a force kept per particle (F in f, on the particles of the boundaries in bits: the
 * dashpots, the pressure loads), exact for the kinetic energy of velocity Verlet's two half kicks.
 * ej_split_work_start, when F_n+1 replaces F_n in the force evaluation: pw, which held F_n . v_n,
 * becomes the first half kick's dt/2 F_n . (v_n + v_half) / 2. ej_split_work_end, after the second
 * half kick: its dt/2 F_n+1 . (v_half + v_n+1) / 2 added to pw is the step's work, summed over r;
 * pw = F_n+1 . v_n+1 for the next step. */
static inline void ej_split_work_start(ej_real dt, const ej_real f[3], const ej_real vh[3], ej_real *pw)
{
  *pw = 0.25 * dt * (*pw + f[0] * vh[0] + f[1] * vh[1] + f[2] * vh[2]);
}

static ej_real ej_split_work_end(const ej_sim *sim, const ej_set *s, ej_range r, uint32_t bits, const ej_real *f,
                                 ej_real *pw)
{
  if (!pw) return 0;
  const ej_real *vh = ej_set_field(s, "v_half"), *v = s->fields[s->f_v].data;
  ej_real w = 0;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    const ej_real *fi = f + 3 * i, *vi = v + 3 * i, *hi = vh + 3 * i;
    if (!(s->bc_mask[i] & bits)) continue;
    w += pw[i] + 0.25 * sim->dt * (fi[0] * (hi[0] + vi[0]) + fi[1] * (hi[1] + vi[1]) + fi[2] * (hi[2] + vi[2]));
    pw[i] = fi[0] * vi[0] + fi[1] * vi[1] + fi[2] * vi[2];
  }
  return w;
}

/* p(t) of a curve: linear between its points, the end values outside. */
static ej_real ej_curve_value(const ej_scene_bc *bc, ej_real t)
{
  const int n = bc->n_curve;
  if (t <= bc->curve_t[0]) return bc->curve_p[0];
  if (t >= bc->curve_t[n - 1]) return bc->curve_p[n - 1];
  int lo = 0, hi = n - 1; /* curve_t[lo] < t < curve_t[hi] */
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (bc->curve_t[mid] <= t) lo = mid;
    else hi = mid;
  }
  const ej_real w = (t - bc->curve_t[lo]) / (bc->curve_t[hi] - bc->curve_t[lo]);
  return bc->curve_p[lo] + w * (bc->curve_p[hi] - bc->curve_p[lo]);
}


ej_real ej_pressure_load(const ej_scene_bc *bc, int dim, const ej_real x[3], ej_real vol0, ej_real t,
                         const ej_blast_pt *blast, ej_real F[3])
{
  ej_real n[3];
  F[0] = F[1] = F[2] = 0;
  if (!ej_bc_face_normal(bc, x, n)) return 0;
  ej_real p;
  switch (bc->source) {
  case EJ_PRESSURE_VALUE: p = bc->p_value; break;
  case EJ_PRESSURE_CURVE: p = ej_curve_value(bc, t); break;
  default:
    p = blast ? ej_blast_eval(blast, t) : ej_blast_pressure(bc->burst, bc->tnt, bc->charge, bc->t_det, x, n, t);
    break;
  }
  const ej_real pa = p * ej_face_area(dim, vol0);
  for (int k = 0; k < 3; ++k) F[k] = -pa * n[k];
  return p;
}

/* The pressure loads' force on particle i at the current time (on the face as it was at t = 0, x the
 * field load_x0) into f, F/m added to a; kept: the field load_blast (the particle's first blast load,
 * computed once), or NULL. */
static void ej_pressure_apply(const ej_sim *sim, const ej_set *s, ej_idx i, const ej_real *x, const ej_real *kept,
                              ej_real f[3], ej_real a[3])
{
  const ej_real *vol0 = s->fields[s->f_vol0].data, *m = s->fields[s->f_m].data;
  f[0] = f[1] = f[2] = 0;
  uint32_t mask = s->bc_mask[i] & s->pr_bits;
  for (int b = 0; mask; ++b, mask >>= 1)
    if (mask & 1u) {
      const ej_scene_bc *bc = &sim->scene->bcs[b];
      ej_blast_pt bp;
      const bool use = bc->source == EJ_PRESSURE_BLAST && kept;
      if (use) memcpy(&bp, kept + EJ_TENSOR9 * i, sizeof bp);
      if (use) kept = NULL;
      ej_real F[3];
      ej_pressure_load(bc, sim->scene->dimension, x + 3 * i, vol0[i], sim->t, use ? &bp : NULL, F);
      for (int k = 0; k < 3; ++k) f[k] += F[k];
    }
  for (int k = 0; k < 3; ++k) a[k] += f[k] / m[i];
}

/* Gravity, the non-reflecting dashpots, then constraints: fixed and prescribed-velocity components
 * get zero acceleration. ctx: a bool, true inside a step (NULL: the force evaluation at t = 0). */
static ej_err ej_body_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)c;
  const bool in_step = ctx && *(const bool *)ctx;
  ej_real *a = s->fields[s->f_a].data;
  const ej_real *g = sim->scene->gravity, *m = s->fields[s->f_m].data, *v = s->fields[s->f_v].data;
  ej_real *pw = ej_set_field(s, "bc_power"), *pw_old = ej_set_field(s, "bc_power_old");
  ej_real *nrf = ej_set_field(s, "nr_force"), *nrp = ej_set_field(s, "nr_power");
  const ej_real *vh = in_step ? ej_set_field(s, "v_half") : NULL;
  ej_real *plf = ej_set_field(s, "load_force"), *plp = ej_set_field(s, "load_power");
  const ej_real *px0 = ej_set_field(s, "load_x0"), *pkept = ej_set_field(s, "load_blast");
  for (ej_idx i = r.begin; i < r.end; ++i) {
    a[3 * i] += g[0], a[3 * i + 1] += g[1], a[3 * i + 2] += g[2];
    if (nrf && (s->bc_mask[i] & s->nr_bits)) {
      /* The dashpot work of the step, exact for the kinetic energy of velocity Verlet: the first
       * half kick's, dt/2 F_n . (v_n + v_half) / 2, from F_n and F_n . v_n (kept at the end of the
       * last step); the second half's in ej_work_chunk. Inside a step F_n+1 comes in the second
       * half kick (ej_nonreflect_kick); at t = 0 it is explicit, at the initial velocity. */
      ej_real *fi = nrf + 3 * i;
      if (in_step) {
        ej_split_work_start(sim->dt, fi, vh + 3 * i, nrp + i);
      } else {
        ej_real K[9];
        bool fixed[3];
        ej_nonreflect_matrix(sim, s, i, s->bc_mask[i] & s->nr_bits, K);
        ej_bc_fixed(sim, s, i, fixed);
        ej_nonreflect_apply(K, fixed, v + 3 * i, m[i], fi, a + 3 * i);
        nrp[i] = fi[0] * v[3 * i] + fi[1] * v[3 * i + 1] + fi[2] * v[3 * i + 2];
      }
    }
    if (plf && (s->bc_mask[i] & s->pr_bits)) {
      /* The load's work as the dashpots' (above): the first half kick's from F_n, the second's in
       * ej_work_chunk; components held by a constraint count too, their constraint power (below)
       * takes the load back. */
      ej_real *fi = plf + 3 * i;
      if (in_step) ej_split_work_start(sim->dt, fi, vh + 3 * i, plp + i);
      ej_pressure_apply(sim, s, i, px0, pkept, fi, a + 3 * i);
      if (!in_step) plp[i] = fi[0] * v[3 * i] + fi[1] * v[3 * i + 1] + fi[2] * v[3 * i + 2];
    }
    ej_real power = 0;
    uint32_t mask = s->bc_mask[i];
    for (int b = 0; mask; ++b, mask >>= 1)
      if (mask & 1u) {
        const ej_scene_bc *bc = &sim->scene->bcs[b];
        if (!ej_bc_active(sim, bc)) continue;
        for (int k = 0; k < 3; ++k)
          if (bc->comp[k]) {
            /* the constraint's force m (0 - a) moving at the prescribed velocity */
            if (bc->kind == EJ_BC_VELOCITY) power -= m[i] * a[3 * i + k] * bc->velocity[k];
            a[3 * i + k] = 0;
          }
      }
    if (pw) {
      pw_old[i] = pw[i];
      pw[i] = power;
    }
  }
  return EJ_OK;
}

/* Passes of a set's method: the configuration's count if the method reports one. */
static int ej_set_passes(const ej_set *s)
{
  const ej_method_ops *m = s->mops;
  if (m->struct_size >= offsetof(ej_method_ops, pass_count) + sizeof m->pass_count && m->pass_count) {
    int n = m->pass_count(s->mstate);
    if (n >= 1 && n <= m->n_passes) return n;
  }
  return m->n_passes;
}

/* in_step: the step loop already zeroed a and the rates (in the kick-drift chunks) and applies
 * gravity and the constraints in the kick chunks (ej_kick_chunk), which saves two parallel
 * regions per step; each particle sees the same operations in the same order. */
/* The write mask of an interaction's pass (post: its post_step) on side k (0: a, 1: b). */
static uint64_t ej_inter_wmask(const ej_inter *in, bool post, int pass, int k)
{
  const int npre = EJ_HAS_OP(in->ops, ej_interaction_ops, n_pre_passes) ? in->ops->n_pre_passes : 0;
  const int q = post ? 0 : 1 + npre + pass;
  return q >= 0 && q <= EJ_MAX_PASS_MASKS ? in->wmask[k][q] : EJ_ALL_FIELDS;
}

/* One pass of an interaction: a's ranges, then b's when the list runs both ways. */
static ej_err ej_inter_pass(ej_sim *sim, ej_inter *in, int pass)
{
  EJ_TRY(ej_ghosts_refresh(sim, in->a));
  if (in->b) EJ_TRY(ej_ghosts_refresh(sim, in->b));
  ej_inter_ctx ic = {in, pass, false};
  /* what the pass writes (every field of both sets unless the interaction says: ABI 1.11) */
  in->a->ghost_dirty |= ej_inter_wmask(in, false, pass, 0);
  if (in->b) in->b->ghost_dirty |= ej_inter_wmask(in, false, pass, 1);
  EJ_TRY(ej_for_chunks(sim, in->a, ej_inter_chunk, &ic));
  if (in->list_ba) {
    ej_inter_ctx rc = {in, pass, true};
    EJ_TRY(ej_for_chunks(sim, in->b, ej_inter_chunk, &rc));
  }
  return EJ_OK;
}

/* The fields each pass of an interaction writes on either set (ABI 1.11 pass_writes), plus the fields an
 * EOS or strength model may write inside any pass (the sets' foreign_mask). An interaction without
 * pass_writes (or one that returns -1) writes every field. Its post_step writes every field, or none
 * with post_step_sums_only (ABI 1.4). Fixed once the interaction exists (ej_sim_create). */
static ej_err ej_inter_write_masks(ej_inter *in)
{
  const ej_interaction_ops *o = in->ops;
  const bool has = EJ_HAS_OP(o, ej_interaction_ops, pass_writes) && o->pass_writes;
  const int npre = EJ_HAS_OP(o, ej_interaction_ops, n_pre_passes) ? o->n_pre_passes : 0;
  const int npass = EJ_HAS_OP(o, ej_interaction_ops, n_passes) && o->n_passes > 1 ? o->n_passes : 1;
  const bool sums_only = EJ_HAS_OP(o, ej_interaction_ops, post_step_sums_only) && o->post_step_sums_only;
  ej_set *sets[2] = {in->a, in->b};
  for (int k = 0; k < 2; ++k)
    for (int q = 0; q <= EJ_MAX_PASS_MASKS; ++q) {
      in->wmask[k][q] = EJ_ALL_FIELDS;
      ej_set *s = sets[k];
      if (!s) continue;
      const int pass = q - 1 - npre; /* for q > 0 */
      if (q > 0 && pass >= npass) continue;
      if (q == 0) { /* post_step: pass_writes does not cover it (its pass numbers include -1) */
        if (sums_only) in->wmask[k][q] = 0;
        continue;
      }
      if (!has) continue;
      const char *names[EJ_MAX_FIELDS];
      const int nw = o->pass_writes(in->state, pass, k, names, EJ_MAX_FIELDS);
      if (nw < 0) continue;
      EJ_ENSURE(nw <= EJ_MAX_FIELDS, EJ_ERR_PLUGIN, "interaction '%s': pass_writes returned %d names (max %d)", o->name,
                nw, EJ_MAX_FIELDS);
      uint64_t mask = 0;
      for (int j = 0; j < nw; ++j) {
        EJ_ENSURE(names[j], EJ_ERR_PLUGIN, "interaction '%s': pass_writes returned a NULL name (pass %d)", o->name,
                  pass);
        const int f = ej_set_find_field(s, names[j]);
        if (f >= 0) mask |= UINT64_C(1) << f;
      }
      in->wmask[k][q] = mask | s->foreign_mask;
    }
  return EJ_OK;
}

/* The method pass before which an interaction's pre-passes run (plugin.h, pre_pass_before): 0, or
 * the first pass of a or b whose write mask has the named field; -1 when neither set has it (or
 * the interaction has no pre-passes). Fixed once the sets and the interaction exist: ej_sim_create
 * stores it in ej_inter.pre_slot. */
static int ej_inter_pre_slot(const ej_inter *in)
{
  const int npre = EJ_HAS_OP(in->ops, ej_interaction_ops, n_pre_passes) ? in->ops->n_pre_passes : 0;
  if (npre <= 0) return -1;
  const char *name = EJ_HAS_OP(in->ops, ej_interaction_ops, pre_pass_before) ? in->ops->pre_pass_before : NULL;
  if (!name) return 0;
  int slot = -1;
  const ej_set *sets[2] = {in->a, in->b};
  for (int k = 0; k < 2; ++k) {
    const ej_set *s = sets[k];
    const int f = s ? ej_set_find_field(s, name) : -1;
    if (f < 0) continue;
    const int np = ej_set_passes(s);
    for (int pass = 0; pass < np; ++pass) {
      const uint64_t mask = pass + 1 <= EJ_MAX_PASS_MASKS ? s->pass_mask[pass + 1] : EJ_ALL_FIELDS;
      if (!(mask & (UINT64_C(1) << f))) continue;
      if (slot < 0 || pass < slot) slot = pass;
      break;
    }
  }
  return slot;
}

/* A method's serial stage (ABI 1.12): after pass `stage` over every range, or EJ_STAGE_FORCES. */
static ej_err ej_serial(ej_set *s, int stage)
{
  if (!EJ_HAS_OP(s->mops, ej_method_ops, serial)) return EJ_OK;
  return s->mops->serial(s->mstate, s, s->list ? &s->list->pub : NULL, stage);
}

static ej_err ej_compute_all(ej_sim *sim, bool in_step)
{
  int max_pass = 0;
  for (int i = 0; i < sim->n_sets; ++i) {
    if (!in_step) {
      sim->sets[i]->ghost_dirty |= sim->sets[i]->step_mask;
      EJ_TRY(ej_for_chunks(sim, sim->sets[i], ej_zero_chunk, NULL));
    }
    const int np = ej_set_passes(sim->sets[i]);
    if (np > max_pass) max_pass = np;
  }
  for (int pass = 0; pass < max_pass; ++pass) {
    /* Interactions' pre-passes (n_pre_passes, plugin.h): x and v of t_n+1, before the method pass
     * ej_inter_pre_slot names (pass 0 unless pre_pass_before, ABI 1.7, names a later one). */
    for (int k = 0; k < sim->n_inter; ++k) {
      ej_inter *in = &sim->inter[k];
      if (in->pre_slot != pass) continue;
      for (int q = -in->ops->n_pre_passes; q < 0; ++q) EJ_TRY(ej_inter_pass(sim, in, q));
    }
    for (int i = 0; i < sim->n_sets; ++i) {
      ej_set *s = sim->sets[i];
      if (pass >= ej_set_passes(s)) continue;
      EJ_TRY(ej_ghosts_refresh(sim, s));
      ej_pass_ctx pc = {pass};
      ej_mark_pass(s, pass);
      ej_err rc = ej_for_chunks(sim, s, ej_compute_chunk, &pc);
      if (rc == EJ_OK) rc = ej_serial(s, pass);
      /* the initial evaluation (also `ejecta check`'s) refusing the input: placed at the set */
      EJ_TRY(in_step ? rc : ej_located(rc, &sim->scene->sets[i].loc));
    }
  }
  /* Interactions see both sets at t_n+1 after all their passes (plugin.h). */
  for (int k = 0; k < sim->n_inter; ++k) {
    ej_inter *in = &sim->inter[k];
    for (int pass = 0; pass < ej_inter_passes(in); ++pass) {
      const ej_err rc = ej_inter_pass(sim, in, pass);
      EJ_TRY(in_step ? rc : ej_located(rc, &sim->scene->interactions[k].loc));
    }
  }
  /* Methods' finish (ABI 1.6): rates that need the interactions' shares. */
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    if (EJ_HAS_OP(s->mops, ej_method_ops, finish) && s->mops->finish)
      EJ_TRY(ej_for_chunks(sim, s, ej_finish_chunk, NULL));
    EJ_TRY(ej_serial(s, EJ_STAGE_FORCES));
  }
  if (!in_step)
    for (int i = 0; i < sim->n_sets; ++i) {
      sim->sets[i]->ghost_dirty |= sim->sets[i]->step_mask;
      EJ_TRY(ej_for_chunks(sim, sim->sets[i], ej_body_chunk, NULL));
    }
  return EJ_OK;
}

/* ------------------------------------------------------------------ time step */

static ej_err ej_dt_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  ej_real dt = INFINITY;
  EJ_TRY(s->mops->stable_dt(s->mstate, s, r, &dt));
  sim->chunk_scratch[c] = dt;
  return EJ_OK;
}

/* Watchdog on the step: it fell to zero, became non-finite or went below time.dt_min or below
 * time.dt_min_ratio times the first adaptive step. Finds what
 * limits it (serially, per particle: the run is over) and names the set and particle. */
static ej_err ej_dt_collapse(ej_sim *sim, ej_real dt)
{
  const ej_scene *sc = sim->scene;
  const ej_set *ws = NULL;
  const char *winter = NULL;
  ej_idx wi = -1;
  ej_real wdt = INFINITY;
  const int depth = ej_error_count();
  for (int k = 0; k < sim->n_sets; ++k) {
    ej_set *s = sim->sets[k];
    for (ej_idx i = 0; i < s->n; ++i) {
      ej_real d = INFINITY;
      if (s->mops->stable_dt(s->mstate, s, (ej_range){i, i + 1}, &d) != EJ_OK) continue;
      if ((isnan(d) && !isnan(wdt)) || d < wdt) ws = s, wi = i, wdt = d;
    }
  }
  for (int k = 0; k < sim->n_inter; ++k) {
    const ej_inter *in = &sim->inter[k];
    ej_real d = INFINITY;
    if (in->ops->stable_dt && in->ops->stable_dt(in->state, in->a, in->b, &d) == EJ_OK && d < wdt)
      winter = in->ops->name, wdt = d;
  }
  ej_error_truncate(depth);
  char why[120];
  if (isfinite(dt) && dt > 0) {
    if (dt < sc->dt_min)
      snprintf(why, sizeof why, "below time.dt_min = %.6g s", sc->dt_min);
    else
      snprintf(why, sizeof why, "below time.dt_min_ratio = %.3g of the first step %.6g s", sc->dt_min_ratio,
               sim->dt_first);
    sim->dt = dt; /* the checkpoint at the failure continues with this step */
  } else {
    snprintf(why, sizeof why, "collapsed");
  }
  if (winter && !(ws && isnan(wdt)))
    EJ_FAIL(EJ_ERR_NUMERIC, "watchdog: time step %.6g s %s at step %lld, t = %.6g s, limited by interaction '%s'", dt,
            why, (long long)sim->step, sim->t, winter);
  if (!ws)
    EJ_FAIL(EJ_ERR_NUMERIC, "watchdog: time step %.6g s %s at step %lld, t = %.6g s", dt, why, (long long)sim->step,
            sim->t);
  const ej_real *x = ws->fields[ws->f_x].data;
  const int32_t *id = ws->fields[ws->f_id].data;
  EJ_FAIL(EJ_ERR_NUMERIC,
          "watchdog: time step %.6g s %s at step %lld, t = %.6g s, limited by set '%s', particle id %d at "
          "(%.6g, %.6g, %.6g) (its stable step %.6g s)",
          dt, why, (long long)sim->step, sim->t, ws->name, id[wi], x[3 * wi], x[3 * wi + 1], x[3 * wi + 2], wdt);
}

static ej_err ej_next_dt(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  ej_real dt = INFINITY;
  if (sc->dt_fixed > 0) {
    dt = sc->dt_fixed;
  } else {
    for (int i = 0; i < sim->n_sets; ++i) {
      ej_set *s = sim->sets[i];
      EJ_TRY(ej_sim_scratch(sim, s));
      EJ_TRY(ej_for_chunks(sim, s, ej_dt_chunk, NULL));
      const int64_t nch = ej_chunk_count(s);
      for (int64_t c = 0; c < nch; ++c) dt = sim->chunk_scratch[c] < dt ? sim->chunk_scratch[c] : dt;
    }
    for (int k = 0; k < sim->n_inter; ++k)
      if (sim->inter[k].ops->stable_dt) {
        ej_real d = INFINITY;
        EJ_TRY(sim->inter[k].ops->stable_dt(sim->inter[k].state, sim->inter[k].a, sim->inter[k].b, &d));
        dt = d < dt ? d : dt;
      }
    dt = ej_comm_min(dt) * sc->cfl;
  }
  if (sc->dt_max > 0 && dt > sc->dt_max) dt = sc->dt_max;
  if (sc->dt_fixed <= 0 && !(sim->dt_first > 0) && isfinite(dt) && dt > 0) sim->dt_first = dt;
  if (!(isfinite(dt) && dt > 0) ||
      (sc->dt_fixed <= 0 && (dt < sc->dt_min || dt < sc->dt_min_ratio * sim->dt_first)))
    return ej_dt_collapse(sim, dt);
  sim->dt = dt;
  return EJ_OK;
}

/* First half kick, drift, and the predictor of velocity and rate fields for the force
 * evaluation at t_n+1 (velocity Verlet; state fields integrated with the same trapezoid); then
 * a and the rates zeroed, and, when *(const bool *)ctx, the chunk's skin watch. */
static ej_err ej_kick_drift_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  const ej_real dt = sim->dt, h = 0.5 * sim->dt;
  ej_real *x = s->fields[s->f_x].data, *v = s->fields[s->f_v].data, *a = s->fields[s->f_a].data;
  ej_real *vh = ej_set_field(s, "v_half");
  const ej_scene *sc = sim->scene;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    for (int k = 0; k < 3; ++k) {
      vh[3 * i + k] = v[3 * i + k] + h * a[3 * i + k];
      x[3 * i + k] += dt * vh[3 * i + k];
      v[3 * i + k] = vh[3 * i + k] + h * a[3 * i + k];
    }
    for (int b = 0; b < sc->n_bcs; ++b) {
      const ej_scene_bc *bc = &sc->bcs[b];
      if (bc->kind != EJ_BC_SYMMETRY || !ej_bc_applies(bc, s->index)) continue;
      /* A particle that crossed a symmetry plane is reflected back, like its mirror image. */
      const ej_real *n = bc->normal;
      ej_real d = (x[3 * i] - bc->point[0]) * n[0] + (x[3 * i + 1] - bc->point[1]) * n[1] +
                  (x[3 * i + 2] - bc->point[2]) * n[2];
      if (d >= 0) continue;
      ej_real vn = vh[3 * i] * n[0] + vh[3 * i + 1] * n[1] + vh[3 * i + 2] * n[2];
      ej_real wn = v[3 * i] * n[0] + v[3 * i + 1] * n[1] + v[3 * i + 2] * n[2];
      for (int k = 0; k < 3; ++k) {
        x[3 * i + k] -= 2 * d * n[k];
        vh[3 * i + k] -= 2 * vn * n[k];
        v[3 * i + k] -= 2 * wn * n[k];
      }
    }
  }
  for (int k = 0; k < s->n_fields; ++k) {
    ej_field *f = &s->fields[k];
    if (f->rate < 0) continue;
    ej_real *y = f->data, *yh = s->fields[f->half].data;
    const ej_real *rt = s->fields[f->rate].data;
    const int nc = f->ncomp;
    for (ej_idx i = r.begin * nc; i < r.end * nc; ++i) {
      yh[i] = y[i] + h * rt[i];
      y[i] = yh[i] + h * rt[i];
    }
  }
  /* a and the rates are not read again before the passes: zero them here (ej_compute_all) */
  EJ_TRY(ej_zero_chunk(sim, s, NULL, c, r));
  /* the skin watch of the drifted chunk (ej_due_chunk: own particles only), in the same region */
  if (*(const bool *)ctx) return ej_due_chunk(sim, s, NULL, c, r);
  return EJ_OK;
}

/* Whether s's method has a post_step that runs in the kick's region (ABI 1.4 post_step_local). */
static bool ej_post_local(const ej_set *s)
{
  return s->mops->post_step && EJ_HAS_OP(s->mops, ej_method_ops, post_step_local);
}

static ej_err ej_post_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)sim, (void)ctx, (void)c;
  return s->mops->post_step(s->mstate, s, r);
}

/* Gravity and the constraints (ej_body_chunk, the end of ej_compute_all), then the second half
 * kick. */
static ej_err ej_kick_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  static const bool in_step = true;
  EJ_TRY(ej_body_chunk(sim, s, (void *)&in_step, c, r));
  const ej_real h = 0.5 * sim->dt;
  ej_real *v = s->fields[s->f_v].data, *a = s->fields[s->f_a].data;
  const ej_real *vh = ej_set_field(s, "v_half");
  for (ej_idx i = r.begin; i < r.end; ++i)
    for (int k = 0; k < 3; ++k) v[3 * i + k] = vh[3 * i + k] + h * a[3 * i + k];
  if (s->nr_bits) {
    ej_real *nrf = ej_set_field(s, "nr_force");
    for (ej_idx i = r.begin; i < r.end; ++i)
      if (s->bc_mask[i] & s->nr_bits) ej_nonreflect_kick(sim, s, i, h, nrf);
  }
  for (int k = 0; k < s->n_fields; ++k) {
    ej_field *f = &s->fields[k];
    if (f->rate < 0) continue;
    ej_real *y = f->data;
    const ej_real *yh = s->fields[f->half].data, *rt = s->fields[f->rate].data;
    const int nc = f->ncomp;
    for (ej_idx i = r.begin * nc; i < r.end * nc; ++i) y[i] = yh[i] + h * rt[i];
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ diagnostics */

static ej_err ej_diag_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r);

typedef struct ej_end_ctx {
  bool post;      /* the method's post_step (post_step_local) after the kick of the chunk */
  bool diag;      /* then the chunk's energy sums and watchdog (ej_diag_chunk) */
  bool with_work; /* ej_diag_chunk's ctx */
} ej_end_ctx;

/* The end of the step for one chunk, in one parallel region per set: second half kick, the
 * method's post_step when it is local to its range (ej_method_ops.post_step_local), the
 * diagnostics. Each particle sees the same operations in the same order as with one region for
 * each, and nothing outside the chunk that these write is read. */
static ej_err ej_end_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  const ej_end_ctx *ec = ctx;
  EJ_TRY(ej_kick_chunk(sim, s, NULL, c, r));
  if (ec->post) EJ_TRY(s->mops->post_step(s->mstate, s, r));
  if (ec->diag) return ej_diag_chunk(sim, s, (void *)&ec->with_work, c, r);
  return EJ_OK;
}

enum { EJ_R_KIN, EJ_R_INT, EJ_R_VISC, EJ_R_PLAS, EJ_R_HG, EJ_R_PX, EJ_R_PY, EJ_R_PZ };

static ej_err ej_energy_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  ej_real acc[EJ_NRED] = {0};
  const ej_real *v = s->fields[s->f_v].data, *m = s->fields[s->f_m].data;
  for (ej_idx i = r.begin; i < r.end; ++i) {
    acc[EJ_R_KIN] += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
    acc[EJ_R_PX] += m[i] * v[3 * i];
    acc[EJ_R_PY] += m[i] * v[3 * i + 1];
    acc[EJ_R_PZ] += m[i] * v[3 * i + 2];
  }
  for (int k = 0; k < s->n_fields; ++k) {
    const ej_field *f = &s->fields[k];
    int slot = f->energy == EJ_ENERGY_INTERNAL ? EJ_R_INT
               : f->energy == EJ_ENERGY_VISCOUS ? EJ_R_VISC
               : f->energy == EJ_ENERGY_PLASTIC ? EJ_R_PLAS
               : f->energy == EJ_ENERGY_HOURGLASS ? EJ_R_HG
                                                   : -1;
    if (slot < 0) continue;
    const ej_real *e = f->data;
    for (ej_idx i = r.begin; i < r.end; ++i) acc[slot] += m[i] * e[i];
  }
  memcpy(sim->chunk_scratch + c * EJ_NSLOT, acc, sizeof acc);
  return EJ_OK;
}

/* Work of gravity over the step (exact for the mid-step velocity) and of prescribed velocities
 * (trapezoidal in the constraint power at the two ends of the step). */
static ej_err ej_work_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  const ej_real *vh = ej_set_field(s, "v_half"), *m = s->fields[s->f_m].data, *g = sim->scene->gravity;
  const ej_real *pw = ej_set_field(s, "bc_power"), *pw_old = ej_set_field(s, "bc_power_old");
  ej_real w = 0, wbc = 0, wnr = 0;
  if (pw)
    for (ej_idx i = r.begin; i < r.end; ++i) wbc += 0.5 * (pw_old[i] + pw[i]);
  /* the dashpots and the pressure loads: the first half kick's work (ej_body_chunk) and the second's */
  wnr += ej_split_work_end(sim, s, r, s->nr_bits, ej_set_field(s, "nr_force"), ej_set_field(s, "nr_power"));
  wnr += ej_split_work_end(sim, s, r, s->pr_bits, ej_set_field(s, "load_force"), ej_set_field(s, "load_power"));
  for (ej_idx i = r.begin; i < r.end; ++i) {
    /* every component: a held one moves at its prescribed velocity (0 for a fix), and the
     * constraint's power (bc_power) takes gravity back there */
    w += m[i] * (g[0] * vh[3 * i] + g[1] * vh[3 * i + 1] + g[2] * vh[3 * i + 2]);
  }
  sim->chunk_scratch[c * EJ_NSLOT + EJ_S_WORK] = (w + wbc) * sim->dt + wnr;
  return EJ_OK;
}

/* Appends one plugin's series to the step's reports: names are fixed on the first call; a
 * plugin that changes its list later is a plugin bug. */
static ej_err ej_reports_add(ej_sim *sim, const char *owner, const ej_series_value *v, int n, int *slot,
                             ej_real *ext)
{
  ej_reports *R = &sim->reports;
  for (int k = 0; k < n; ++k, ++*slot) {
    char name[sizeof R->names[0]];
    snprintf(name, sizeof name, "%s/%s", owner, v[k].name);
    if (!R->fixed) {
      EJ_ENSURE(*slot < EJ_MAX_REPORTS, EJ_ERR_PLUGIN, "more than %d reported series", EJ_MAX_REPORTS);
      memcpy(R->names[*slot], name, sizeof name);
      R->n = *slot + 1;
    } else {
      EJ_ENSURE(*slot < R->n && !strcmp(R->names[*slot], name), EJ_ERR_PLUGIN,
                "'%s' changed its reported series after the first step (%s)", owner, name);
    }
    R->values[*slot] = v[k].value;
    if (v[k].role == EJ_SERIES_WORK) *ext += v[k].value;
    else if (v[k].role == EJ_SERIES_DISSIPATED) *ext -= v[k].value;
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ probes
 *
 * A probe (scene `probes:`, docs/core.md "Probes") adds columns to the step's series, after the
 * plugins' reports: /series/probe/<name>/<column>, one row per step like the energy budget.
 *   gauge (follow: false): a point fixed in space. Each column is the Shepard average
 *     sum_j w_j f_j / sum_j w_j over the set's particles j (and images) whose support covers the point,
 *     w_j = V_j f(q) / h_j^dim with the cubic spline f (f(0) = 1, zero from q = 2 on), h_j = R_j / 2,
 *     R_j the particle's search radius (or the probe's radius), q = |x_j - point| / h_j and V_j
 *     its volume (m/rho, else vol, else vol0, else 1). It reproduces a constant exactly, and a
 *     linear field where the particles lie symmetrically about the point. Column `count`: the
 *     number of particles with w_j > 0; the fields are NaN when it is 0 (no material there).
 *     The set's mirror and periodic images (its ghosts, from their sources' current values) are in
 *     the sums, so a gauge on a symmetry plane of a quarter model reads the full model's value.
 *   tracer (follow: true): the particle nearest to the point in the initial state (the smaller id
 *     on a tie), found again by its id after every re-sort; columns its position, then its fields.
 * One serial pass over the set per gauge and step, in particle order: the values do not depend on
 * the thread count. The tracer's particle is chosen from the scene's initial state before any
 * restart reads a checkpoint, so a restarted run follows the same particle. */

static const char *const ej_comp_vec[] = {"x", "y", "z"};
static const char *const ej_comp_sym[] = {"xx", "yy", "zz", "xy", "yz", "zx"};
static const char *const ej_comp_t9[] = {"xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"};

static ej_err ej_probe_cols(ej_probe *P, int dim)
{
  const ej_scene_probe *sp = P->sp;
  const ej_set *s = P->set;
  int c = 0;
  if (sp->follow)
    for (int d = 0; d < dim; ++d, ++c) {
      P->col_field[c] = -1, P->col_comp[c] = d;
      snprintf(P->col_name[c], sizeof P->col_name[c], "%s", ej_comp_vec[d]);
    }
  else {
    P->col_field[c] = -1, P->col_comp[c] = 0;
    snprintf(P->col_name[c], sizeof P->col_name[c], "count");
    ++c;
  }
  for (int k = 0; k < sp->n_fields; ++k) {
    const int f = ej_set_find_field(s, sp->fields[k]);
    if (f < 0) {
      const char *cands[EJ_MAX_FIELDS];
      for (int j = 0; j < s->n_fields; ++j) cands[j] = s->fields[j].name;
      const char *near = ej_nearest_word(sp->fields[k], cands, s->n_fields);
      if (near)
        return ej_error_input(&sp->field_locs[k], "probe '%s': set '%s' has no field '%s'; did you mean '%s'?",
                              sp->name, s->name, sp->fields[k], near);
      return ej_error_input(&sp->field_locs[k], "probe '%s': set '%s' has no field '%s' ('ejecta describe %s' "
                            "lists the method's fields)", sp->name, s->name, sp->fields[k], s->mops->name);
    }
    const ej_field_kind kind = s->fields[f].kind;
    const int nc = kind == EJ_VEC3 ? dim : kind == EJ_INT ? 1 : (int)kind;
    EJ_ENSURE(c + nc <= EJ_MAX_PROBE_COLS, EJ_ERR_INTERNAL, "probe '%s': too many columns", sp->name);
    for (int q = 0; q < nc; ++q, ++c) {
      P->col_field[c] = f, P->col_comp[c] = q;
      if (kind == EJ_SCALAR || kind == EJ_INT) snprintf(P->col_name[c], sizeof P->col_name[c], "%s", sp->fields[k]);
      else
        snprintf(P->col_name[c], sizeof P->col_name[c], "%s_%s", sp->fields[k],
                 kind == EJ_VEC3 ? ej_comp_vec[q] : kind == EJ_SYM6 ? ej_comp_sym[q] : ej_comp_t9[q]);
    }
  }
  P->n_cols = c;
  return EJ_OK;
}

ej_idx ej_set_nearest(const ej_set *s, int dim, const ej_real p[3], ej_real *d2)
{
  const ej_real *x = s->fields[s->f_x].data;
  const int32_t *id = s->fields[s->f_id].data;
  ej_real best = INFINITY;
  ej_idx at = -1;
  for (ej_idx j = 0; j < s->n; ++j) {
    ej_real r2 = 0;
    for (int d = 0; d < dim; ++d) r2 += (x[3 * j + d] - p[d]) * (x[3 * j + d] - p[d]);
    if (r2 < best || (at >= 0 && r2 == best && id[j] < id[at])) best = r2, at = j;
  }
  *d2 = best;
  return at;
}

/* The series the core adds to the plugins' reports: output.set_series's per-set sums, and the
 * probes (columns, and each tracer's particle, from the sets as generated, before any sort or
 * restart). Input errors (an unknown field, a gauge without a radius) exit 2. */
static ej_err ej_series_setup(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  if (sc->set_series) {
    if (EJ_NRED * sim->n_sets > EJ_MAX_REPORTS / 2)
      return ej_error_input(&sc->output_loc, "output set_series: %d sets make %d columns; at most %d fit", sim->n_sets,
                            EJ_NRED * sim->n_sets, EJ_MAX_REPORTS / 2);
    sim->set_sums = ej_calloc((size_t)sim->n_sets, sizeof *sim->set_sums);
    EJ_ENSURE(sim->set_sums, EJ_ERR_MEM, "out of memory");
  }
  if (sc->n_probes == 0) return EJ_OK;
  sim->probes = ej_calloc((size_t)sc->n_probes, sizeof *sim->probes);
  EJ_ENSURE(sim->probes, EJ_ERR_MEM, "out of memory");
  sim->n_probes = sc->n_probes;
  int cols = 0;
  for (int k = 0; k < sc->n_probes; ++k) {
    ej_probe *P = &sim->probes[k];
    const ej_scene_probe *sp = &sc->probes[k];
    P->sp = sp;
    P->set = sim->sets[sp->set];
    snprintf(P->owner, sizeof P->owner, "probe/%s", sp->name);
    EJ_TRY(ej_probe_cols(P, sim->dim));
    cols += P->n_cols;
    const ej_set *s = P->set;
    if (!sp->follow && sp->radius <= 0 && !EJ_HAS_OP(s->mops, ej_method_ops, support))
      return ej_error_input(&sp->loc, "probe '%s': set '%s' (method %s) has no search radius; give the probe a "
                            "radius", sp->name, s->name, s->mops->name);
    if (sp->follow) {
      ej_real d2;
      P->at = ej_set_nearest(s, sim->dim, sp->point, &d2);
      EJ_ENSURE(P->at >= 0, EJ_ERR_INTERNAL, "set '%s' is empty", s->name);
      P->id = ((const int32_t *)s->fields[s->f_id].data)[P->at];
    }
  }
  /* the series table holds EJ_MAX_REPORTS columns, the plugins' reports included */
  const int set_cols = sim->set_sums ? EJ_NRED * sim->n_sets : 0;
  if (cols + set_cols > EJ_MAX_REPORTS / 2)
    return ej_error_input(&sc->probes[0].loc, "the probes record %d columns in all (and output set_series %d); at "
                          "most %d fit", cols, set_cols, EJ_MAX_REPORTS / 2);
  return EJ_OK;
}

static ej_real ej_probe_value(const ej_set *s, int f, int q, ej_idx j)
{
  const ej_field *F = &s->fields[f];
  if (F->kind == EJ_INT) return (ej_real)((const int32_t *)F->data)[j];
  const int nc = (int)F->kind;
  return ((const ej_real *)F->data)[(size_t)nc * j + (size_t)q];
}

/* A particle's volume for the gauge weights: m/rho, else vol (or vol0), else 1. */
static ej_real ej_probe_volume(const ej_real *m, const ej_real *rho, const ej_real *vol, ej_idx j)
{
  return m && rho && rho[j] > 0 ? m[j] / rho[j] : vol ? vol[j] : 1.0;
}

/* A gauge's weight of a particle (or image) at x with search radius Rj and volume V; 0 outside.
 * The spline's normalisation cancels in the Shepard average but for the 1/h^dim of particles with
 * different supports. */
static ej_real ej_probe_weight(const ej_scene_probe *sp, int dim, const ej_real *x, ej_real Rj, ej_real V)
{
  ej_real r2 = 0;
  for (int d = 0; d < dim; ++d) r2 += (x[d] - sp->point[d]) * (x[d] - sp->point[d]);
  if (sp->radius > 0) Rj = sp->radius;
  if (!(r2 < Rj * Rj)) return 0;
  const ej_real h = 0.5 * Rj;
  return V * ej_spline_shape(sqrt(r2) / h) / (dim == 1 ? h : dim == 2 ? h * h : h * h * h);
}

static void ej_probe_eval(const ej_sim *sim, ej_probe *P, ej_real *out)
{
  const int dim = sim->dim;
  const ej_set *s = P->set;
  const ej_scene_probe *sp = P->sp;
  const ej_real *x = s->fields[s->f_x].data;
  if (sp->follow) {
    const int32_t *id = s->fields[s->f_id].data;
    if (!(P->at < s->n && id[P->at] == P->id))
      for (ej_idx j = 0; j < s->n; ++j)
        if (id[j] == P->id) {
          P->at = j;
          break;
        }
    const ej_idx j = P->at;
    for (int c = 0; c < P->n_cols; ++c)
      out[c] = P->col_field[c] < 0 ? x[3 * j + P->col_comp[c]] : ej_probe_value(s, P->col_field[c], P->col_comp[c], j);
    return;
  }
  const int fr = ej_set_find_field(s, "rho"), fv = ej_set_find_field(s, "vol");
  const ej_real *m = s->f_m >= 0 ? s->fields[s->f_m].data : NULL, *rho = fr >= 0 ? s->fields[fr].data : NULL;
  const ej_real *vol = fv >= 0 ? s->fields[fv].data : s->f_vol0 >= 0 ? s->fields[s->f_vol0].data : NULL;
  const ej_real *R = s->radius;
  ej_real wsum = 0;
  int64_t count = 0;
  for (int c = 1; c < P->n_cols; ++c) out[c] = 0;
  for (ej_idx j = 0; j < s->n; ++j) {
    const ej_real w = ej_probe_weight(sp, dim, x + 3 * j, R ? R[j] : 0, ej_probe_volume(m, rho, vol, j));
    if (!(w > 0)) continue;
    wsum += w, ++count;
    for (int c = 1; c < P->n_cols; ++c) out[c] += w * ej_probe_value(s, P->col_field[c], P->col_comp[c], j);
  }
  /* mirror and periodic images: the set's ghosts, each from its source's current state (vectors
   * and tensors transformed like a ghost refresh), so that a gauge on a symmetry plane averages
   * both sides of it */
  for (ej_idx g = 0; g < s->n_ghost; ++g) {
    const ej_idx j = s->ghost_src[g];
    ej_real y[3];
    ej_set_ghost_value(s, s->f_x, sim->xforms, g, y);
    const ej_real w = ej_probe_weight(sp, dim, y, R ? R[j] : 0, ej_probe_volume(m, rho, vol, j));
    if (!(w > 0)) continue;
    wsum += w, ++count;
    ej_real val[9];
    for (int c = 1; c < P->n_cols; ++c) {
      const ej_field *F = &s->fields[P->col_field[c]];
      if (F->kind == EJ_INT || F->ncomp == 1) {
        out[c] += w * ej_probe_value(s, P->col_field[c], P->col_comp[c], j);
        continue;
      }
      /* a field's components are consecutive columns: its image value once, at the first */
      if (P->col_comp[c] == 0) ej_set_ghost_value(s, P->col_field[c], sim->xforms, g, val);
      out[c] += w * val[P->col_comp[c]];
    }
  }
  out[0] = (ej_real)count;
  for (int c = 1; c < P->n_cols; ++c) out[c] = wsum > 0 ? out[c] / wsum : NAN;
}

/* Series of every method and interaction; returns the plugins' net external work. */
static ej_err ej_reports_collect(ej_sim *sim, ej_real *ext)
{
  int slot = 0;
  *ext = 0;
  ej_series_value v[EJ_MAX_SERIES];
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    if (!EJ_HAS_OP(s->mops, ej_method_ops, report)) continue;
    int n = 0;
    EJ_TRY(s->mops->report(s->mstate, s, v, EJ_MAX_SERIES, &n));
    EJ_ENSURE(n >= 0 && n <= EJ_MAX_SERIES, EJ_ERR_PLUGIN, "method '%s' reported %d series", s->mops->name, n);
    EJ_TRY(ej_reports_add(sim, s->name, v, n, &slot, ext));
  }
  for (int k = 0; k < sim->n_inter; ++k) {
    ej_inter *in = &sim->inter[k];
    if (!EJ_HAS_OP(in->ops, ej_interaction_ops, report)) continue;
    int n = 0;
    EJ_TRY(in->ops->report(in->state, v, EJ_MAX_SERIES, &n));
    EJ_ENSURE(n >= 0 && n <= EJ_MAX_SERIES, EJ_ERR_PLUGIN, "interaction '%s' reported %d series", in->ops->name, n);
    char owner[80];
    snprintf(owner, sizeof owner, "%s_%d", in->ops->name, k);
    EJ_TRY(ej_reports_add(sim, owner, v, n, &slot, ext));
  }
  for (int k = 0; k < sim->n_probes; ++k) {
    ej_probe *P = &sim->probes[k];
    ej_real val[EJ_MAX_PROBE_COLS];
    ej_series_value pv[EJ_MAX_PROBE_COLS];
    ej_probe_eval(sim, P, val);
    for (int c = 0; c < P->n_cols; ++c) pv[c] = (ej_series_value){.name = P->col_name[c], .value = val[c]};
    EJ_TRY(ej_reports_add(sim, P->owner, pv, P->n_cols, &slot, ext));
  }
  if (sim->set_sums) { /* output.set_series, in the order of EJ_R_* */
    static const char *const cols[EJ_NRED] = {"kinetic", "internal", "viscous", "plastic", "hourglass",
                                              "momentum_x", "momentum_y", "momentum_z"};
    for (int i = 0; i < sim->n_sets; ++i) {
      ej_series_value sv[EJ_NRED];
      for (int k = 0; k < EJ_NRED; ++k) sv[k] = (ej_series_value){.name = cols[k], .value = sim->set_sums[i][k]};
      char owner[80];
      snprintf(owner, sizeof owner, "set/%s", sim->sets[i]->name);
      EJ_TRY(ej_reports_add(sim, owner, sv, EJ_NRED, &slot, ext));
    }
  }
  EJ_ENSURE(!sim->reports.fixed || slot == sim->reports.n, EJ_ERR_PLUGIN, "a plugin changed its reported series");
  sim->reports.fixed = true;
  return EJ_OK;
}

/* True when every value of d[0..n) is finite: branch-free over the block (a value is NaN or
 * infinite iff all its exponent bits are set), so the loop vectorises. */
static bool ej_watch_block_finite(const ej_real *restrict d, size_t n)
{
  const uint64_t exp_mask = UINT64_C(0x7ff0000000000000);
  uint64_t bad = 0;
  for (size_t k = 0; k < n; ++k) {
    uint64_t b;
    memcpy(&b, d + k, sizeof b);
    bad |= (uint64_t)((b & exp_mask) == exp_mask);
  }
  return bad == 0;
}

/* NaN/inf watchdog over every ghosted real field: the first bad particle (lowest index, then
 * lowest field) is reported, whatever the thread count. Each field's block of the chunk is
 * tested at once (field-outer, contiguous); only a chunk with a non-finite value is scanned
 * again particle by particle to name the first one. */
static ej_err ej_watch_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  (void)ctx;
  ej_real bad_p = -1, bad_f = -1;
  const ej_shape *dom = sim->scene->domain;
  const ej_real *x = s->fields[s->f_x].data;
  bool finite = true;
  for (int k = 0; k < s->n_fields && finite; ++k) {
    const ej_field *f = &s->fields[k];
    if (f->kind == EJ_INT || (f->flags & EJ_FIELD_NO_GHOST)) continue;
    const size_t nc = (size_t)f->ncomp;
    finite = ej_watch_block_finite((const ej_real *)f->data + (size_t)r.begin * nc, (size_t)(r.end - r.begin) * nc);
  }
  if (finite) {
    if (dom)
      for (ej_idx p = r.begin; p < r.end; ++p)
        if (!ej_shape_contains(dom, x + 3 * (size_t)p)) {
          bad_p = p, bad_f = -2; /* a particle outside the scene's domain */
          break;
        }
    sim->chunk_scratch[c * EJ_NSLOT + EJ_S_BADP] = bad_p;
    sim->chunk_scratch[c * EJ_NSLOT + EJ_S_BADF] = bad_f;
    return EJ_OK;
  }
  for (ej_idx p = r.begin; p < r.end && bad_p < 0; ++p) {
    for (int k = 0; k < s->n_fields && bad_p < 0; ++k) {
      const ej_field *f = &s->fields[k];
      if (f->kind == EJ_INT || (f->flags & EJ_FIELD_NO_GHOST)) continue;
      const ej_real *d = (const ej_real *)f->data + (size_t)p * f->ncomp;
      for (int q = 0; q < f->ncomp; ++q)
        if (!isfinite(d[q])) {
          bad_p = p;
          bad_f = k;
          break;
        }
    }
    /* bad_f = -2: a particle outside the scene's domain. */
    if (bad_p < 0 && dom && !ej_shape_contains(dom, x + 3 * (size_t)p)) bad_p = p, bad_f = -2;
  }
  sim->chunk_scratch[c * EJ_NSLOT + EJ_S_BADP] = bad_p;
  sim->chunk_scratch[c * EJ_NSLOT + EJ_S_BADF] = bad_f;
  return EJ_OK;
}

/* Work, energies and the watchdog of one chunk in one pass (one parallel region per set). */
static ej_err ej_diag_chunk(ej_sim *sim, ej_set *s, void *ctx, int64_t c, ej_range r)
{
  if (*(const bool *)ctx) EJ_TRY(ej_work_chunk(sim, s, NULL, c, r));
  EJ_TRY(ej_energy_chunk(sim, s, NULL, c, r));
  return ej_watch_chunk(sim, s, NULL, c, r);
}

/* The NaN/inf and domain watchdog's message for particle bad of s (fk: the field, -2: outside). */
static ej_err ej_watch_fail(ej_sim *sim, const ej_set *s, ej_idx bad, int fk)
{
  const ej_real *x = s->fields[s->f_x].data, *v = s->fields[s->f_v].data;
  const int32_t *id = s->fields[s->f_id].data;
  if (fk == -2)
    EJ_FAIL(EJ_ERR_NUMERIC,
            "watchdog: particle %s the domain (%s:%d) at step %lld, t = %.6g s, set '%s', particle id %d at "
            "(%.6g, %.6g, %.6g), velocity (%.6g, %.6g, %.6g) m/s",
            sim->step > 0 ? "left" : "starts outside",
            sim->scene->domain_loc.file ? sim->scene->domain_loc.file : "scene", sim->scene->domain_loc.line,
            (long long)sim->step, sim->t, s->name, id[bad], x[3 * bad], x[3 * bad + 1], x[3 * bad + 2], v[3 * bad],
            v[3 * bad + 1], v[3 * bad + 2]);
  const ej_field *f = &s->fields[fk];
  EJ_FAIL(EJ_ERR_NUMERIC,
          "watchdog: non-finite '%s' at step %lld, t = %.6g s, set '%s', particle id %d at (%.6g, %.6g, %.6g)",
          f->name, (long long)sim->step, sim->t, s->name, id[bad], x[3 * bad], x[3 * bad + 1], x[3 * bad + 2]);
}

/* The step's sums over the sets, added set by set in set order and chunk by chunk in chunk
 * order (the same sums whichever region computed the chunks' parts). */
typedef struct ej_diag_acc {
  ej_real tot[EJ_NRED], work;
  const ej_set *bad_set;
  ej_idx bad;
  int bad_f;
} ej_diag_acc;

static void ej_diag_init(ej_diag_acc *A)
{
  memset(A, 0, sizeof *A);
  A->bad = -1, A->bad_f = -1;
}

/* Adds s's chunk results (ej_diag_chunk's slots of the scratch) to A. */
static void ej_diag_add(const ej_sim *sim, const ej_set *s, bool with_work, ej_diag_acc *A)
{
  const int64_t nch = ej_chunk_count(s);
  ej_real *ps = sim->set_sums ? sim->set_sums[s->index] : NULL; /* output.set_series */
  if (ps)
    for (int k = 0; k < EJ_NRED; ++k) ps[k] = 0;
  for (int64_t c = 0; c < nch; ++c) {
    const ej_real *cs = sim->chunk_scratch + c * EJ_NSLOT;
    if (with_work) A->work += cs[EJ_S_WORK];
    for (int k = 0; k < EJ_NRED; ++k) A->tot[k] += cs[k];
    if (ps)
      for (int k = 0; k < EJ_NRED; ++k) ps[k] += cs[k];
    if (!A->bad_set && cs[EJ_S_BADP] >= 0) A->bad_set = s, A->bad = (ej_idx)cs[EJ_S_BADP], A->bad_f = (int)cs[EJ_S_BADF];
  }
}

/* Energy budget from the sums of every set (with the step's work of gravity and prescribed
 * velocities when they were summed), the plugins' series, then the watchdog: the first bad
 * particle of the first set that has one (lowest chunk, then lowest index, then lowest field),
 * whatever the thread count. */
static ej_err ej_diag_finish(ej_sim *sim, ej_diag_acc *A)
{
  ej_real *tot = A->tot;
  ej_comm_sum(tot, EJ_NRED);
  ej_comm_sum(&A->work, 1);
  ej_energy *E = &sim->energy;
  E->kinetic = tot[EJ_R_KIN];
  E->internal = tot[EJ_R_INT];
  E->viscous = tot[EJ_R_VISC];
  E->plastic = tot[EJ_R_PLAS];
  E->hourglass = tot[EJ_R_HG];
  E->momentum[0] = tot[EJ_R_PX], E->momentum[1] = tot[EJ_R_PY], E->momentum[2] = tot[EJ_R_PZ];
  E->work_gravity += A->work;
  ej_real ext_plugins;
  EJ_TRY(ej_reports_collect(sim, &ext_plugins));
  E->external = E->work_gravity + ext_plugins;
  E->balance = E->kinetic + E->internal - E->total0 - E->external;
  if (A->bad_set) return ej_watch_fail(sim, A->bad_set, A->bad, A->bad_f);
  return EJ_OK;
}

/* The diagnostics in a region of their own per set (set-up, and steps that cannot fuse them). */
static ej_err ej_diagnostics(ej_sim *sim, bool with_work)
{
  ej_diag_acc A;
  ej_diag_init(&A);
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    EJ_TRY(ej_sim_scratch(sim, s));
    EJ_TRY(ej_for_chunks(sim, s, ej_diag_chunk, &with_work));
    ej_diag_add(sim, s, with_work, &A);
  }
  return ej_diag_finish(sim, &A);
}

/* After a numerical failure: a frame and a checkpoint of the state at the failure, so that the
 * output shows what went wrong and `--restart NAME.partial` can read it. */
static bool ej_fail_keep(ej_sim *sim)
{
  if (!sim->out) return false;
  const int depth = ej_error_count();
  bool ok = ej_output_frame(sim->out, sim) == EJ_OK;
  if (ok) sim->frame++;
  ok = ok && ej_output_checkpoint(sim->out, sim) == EJ_OK;
  ej_error_truncate(depth);
  return ok;
}

/* ej_output_close(out, true) finished the file under its final name; a failed or stopped run must
 * not leave a file that looks whole, so it goes back to NAME.partial and the XDMF sidecar is
 * removed. say: print where the state is (a stopped run: the CLI says it). */
static void ej_fail_rename(ej_sim *sim, ej_err close_rc, bool say)
{
  if (close_rc != EJ_OK) return;
  const char *path = sim->out_path, *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
  const size_t n = strlen(path);
  char *partial = ej_malloc(n + sizeof ".partial"), *xdmf = ej_malloc(n + sizeof ".xdmf");
  if (partial && xdmf) {
    memcpy(partial, path, n);
    memcpy(partial + n, ".partial", sizeof ".partial");
    /* the sidecar's name as output.c forms it: extension replaced by .xdmf */
    size_t stem = (!dot || (slash && dot < slash) || dot == (slash ? slash + 1 : path) || !strcmp(dot, ".xdmf"))
                      ? n : (size_t)(dot - path);
    memcpy(xdmf, path, stem);
    memcpy(xdmf + stem, ".xdmf", sizeof ".xdmf");
    if (rename(path, partial) == 0) {
      remove(xdmf);
      if (say) /* not for a stopped run: the CLI says where its state is */
        fprintf(stderr,
                "ejecta: the state at the failure (step %lld, t = %.6g s: last frame and checkpoint) is in "
                "'%s'; 'ejecta run SCENE --restart %s' reads it\n",
                (long long)sim->step, sim->t, partial, partial);
    }
  }
  ej_free(partial);
  ej_free(xdmf);
}

/* ------------------------------------------------------------------ output scheduling */

static ej_err ej_maybe_output(ej_sim *sim, bool last)
{
  const ej_scene *sc = sim->scene;
  const ej_real eps = 1e-12 * (sc->t_end > 0 ? sc->t_end : 1);
  if (last || sim->t >= sim->next_output - eps) {
    EJ_TRY(ej_output_frame(sim->out, sim));
    sim->frame++;
    if (sc->output_every > 0)
      while (sim->next_output <= sim->t + eps) sim->next_output += sc->output_every;
    else
      sim->next_output = INFINITY;
  }
  if (last || (sc->checkpoint_every > 0 && sim->t >= sim->next_checkpoint - eps)) {
    if (sc->checkpoint_every > 0)
      while (sim->next_checkpoint <= sim->t + eps) sim->next_checkpoint += sc->checkpoint_every;
    EJ_TRY(ej_output_checkpoint(sim->out, sim));
  }
  return EJ_OK;
}

/* ------------------------------------------------------------------ public API */

/* `domain` must hold every initial particle: one outside it is bad input (a domain drawn too small or
 * a set placed outside it), found by `ejecta check` too, not a run that stops at step 0 with exit 1. */
static ej_err ej_domain_holds_start(const ej_sim *sim)
{
  const ej_shape *dom = sim->scene->domain;
  for (int i = 0; i < sim->n_sets; ++i) {
    const ej_set *s = sim->sets[i];
    const ej_real *x = s->fields[s->f_x].data;
    const int32_t *id = s->fields[s->f_id].data;
    for (ej_idx p = 0; p < s->n; ++p)
      if (!ej_shape_contains(dom, x + 3 * (size_t)p))
        return ej_error_input(&sim->scene->domain_loc,
                              "set '%s' starts with particle id %d at (%g, %g, %g) outside the domain (expected a "
                              "domain that holds every initial particle)",
                              s->name, (int)id[p], x[3 * p], x[3 * p + 1], x[3 * p + 2]);
  }
  return EJ_OK;
}

ej_err ej_sim_create(ej_scene *scene, ej_registry *reg, const ej_run_opts *opts, ej_sim **out)
{
  ej_sim *sim = ej_calloc(1, sizeof *sim);
  EJ_ENSURE(sim, EJ_ERR_MEM, "out of memory");
  ej_err rc;
  sim->scene = scene;
  sim->reg = reg;
  sim->dim = scene->dimension;
  sim->chunk = EJ_CHUNK;
  sim->xforms[0] = (ej_xform){.Q = {1, 0, 0, 0, 1, 0, 0, 0, 1}};
  sim->n_xforms = 1;
  if (opts && opts->threads > 0) {
#ifdef _OPENMP
    omp_set_num_threads(opts->threads);
#endif
  }
#ifdef _OPENMP
  /* The chunk loops (ej_for_chunks) take the core's affinity schedule (own block first, then
   * stealing) unless the user sets OMP_SCHEDULE (e.g. "static", "dynamic,1"): then OpenMP's
   * runtime schedule with that value. Results do not depend on it: every chunk computes the same
   * values whichever thread runs it. */
  {
    const char *sched = getenv("OMP_SCHEDULE");
    sim->affinity = !(sched && *sched);
    ej_set_chunk_schedule(sched);
  }
#endif
  sim->progress = opts && opts->progress;
  {
    const char *gc = getenv("EJECTA_GHOST_CHECK");
    sim->ghost_check = gc && *gc && strcmp(gc, "0") != 0;
    const char *prof = getenv("EJECTA_PROFILE");
    sim->profile = prof && *prof && strcmp(prof, "0") != 0;
    ej_prof.level = sim->profile ? (strcmp(prof, "2") == 0 ? 2 : 1) : 0;
  }
  if (opts && opts->t_end > 0) scene->t_end = opts->t_end;
  EJ_TRY_GOTO(rc, ej_models_create(sim), out_destroy);
  EJ_TRY_GOTO(rc, ej_sets_create(sim), out_destroy);
  if (scene->domain && !(opts && opts->restart)) EJ_TRY_GOTO(rc, ej_domain_holds_start(sim), out_destroy);
  EJ_TRY_GOTO(rc, ej_check_output_fields(sim), out_destroy);
  sim->inter = ej_calloc((size_t)scene->n_interactions + 1, sizeof *sim->inter);
  EJ_ENSURE(sim->inter, EJ_ERR_MEM, "out of memory");
  for (int k = 0; k < scene->n_interactions; ++k) {
    const ej_scene_interaction *si = &scene->interactions[k];
    ej_inter *in = &sim->inter[sim->n_inter++];
    in->ops = si->ops;
    in->config = si->config;
    in->a = sim->sets[si->set_a];
    in->b = si->set_b >= 0 ? sim->sets[si->set_b] : NULL;
    if (in->b) {
      EJ_TRY_GOTO(rc, ej_nbrlist_create(&in->list), out_destroy);
      if (EJ_HAS_OP(in->ops, ej_interaction_ops, both_ways)) EJ_TRY_GOTO(rc, ej_nbrlist_create(&in->list_ba), out_destroy);
      in->a->in_interaction = in->b->in_interaction = true;
      if (EJ_HAS_OP(in->ops, ej_interaction_ops, needs_images)) in->a->wants_images = in->b->wants_images = true;
    }
  }
  /* every interaction's wants_images is known: which sets get images (ej_set_has_images), before
   * any create, so that a plugin that cannot take them refuses the scene at check time */
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    /* the sets ej_lists_from_build makes images of: a list of their own, or wants_images */
    s->has_images = false;
    if (s->nbr_config == EJ_NBR_NONE && !s->wants_images) continue;
    for (int b = 0; b < scene->n_bcs && !s->has_images; ++b) s->has_images = ej_bc_images(&scene->bcs[b], s->index);
  }
  for (int k = 0; k < sim->n_inter; ++k) {
    ej_inter *in = &sim->inter[k];
    const ej_scene_interaction *si = &scene->interactions[k];
    EJ_TRY_GOTO(rc, ej_located(in->ops->create(in->config, in->a, in->b, &in->state), &si->loc), out_destroy);
    in->pre_slot = ej_inter_pre_slot(in);
    EJ_TRY_GOTO(rc, ej_located(ej_inter_write_masks(in), &si->loc), out_destroy);
  }
  EJ_TRY_GOTO(rc, ej_series_setup(sim), out_destroy);
  const char *path = opts && opts->output ? opts->output : scene->output_file;
  sim->out_path = ej_strdup(path);
  EJ_ENSURE(sim->out_path, EJ_ERR_MEM, "out of memory");
  if (opts && opts->check_only) {
    /* the methods' setup and the first force evaluation too (they read the initial state and what
     * the scene points to: files, shapes, neighbours), so that what they refuse is found before a
     * run; nothing is written */
    EJ_TRY_GOTO(rc, ej_sets_setup(sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_rebuild(sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_compute_all(sim, false), out_destroy);
    *out = sim;
    return EJ_OK;
  }
  if (opts && opts->restart) {
    /* The methods' setup runs on the scene's initial state first, as in a fresh run, so that a
     * method's own arrays (rkpm's MSNNI face data, sized and keyed by particle id) exist; the
     * checkpoint then overwrites every field setup wrote. Read before opening the output: the
     * restart file may be this run's own .partial. */
    EJ_TRY_GOTO(rc, ej_sets_setup(sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_checkpoint_read(opts->restart, sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_output_open(&sim->out, sim, sim->out_path), out_destroy);
    EJ_TRY_GOTO(rc, ej_lists_from_build(sim), out_destroy);
  } else {
    EJ_TRY_GOTO(rc, ej_output_open(&sim->out, sim, sim->out_path), out_destroy);
    EJ_TRY_GOTO(rc, ej_sets_setup(sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_rebuild(sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_compute_all(sim, false), out_destroy);
    rc = ej_diagnostics(sim, false);
    sim->energy.total0 = sim->energy.kinetic + sim->energy.internal;
    sim->energy.balance = 0;
    EJ_TRY_GOTO(rc, rc, out_destroy);
    EJ_TRY_GOTO(rc, ej_next_dt(sim), out_destroy);
    sim->next_output = 0;
    sim->next_checkpoint = scene->checkpoint_every > 0 ? scene->checkpoint_every : INFINITY;
    EJ_TRY_GOTO(rc, ej_output_series(sim->out, sim), out_destroy);
    EJ_TRY_GOTO(rc, ej_maybe_output(sim, false), out_destroy);
  }
  *out = sim;
  return EJ_OK;
out_destroy:
  ej_sim_destroy(sim);
  return rc;
}

static void ej_progress(ej_sim *sim, double t0, int64_t step0, int64_t psteps, bool final)
{
  static double last;
  double now = ej_wall();
  if (!final && now - last < 0.5) return;
  last = now;
  double el = now - t0, frac = sim->scene->t_end > 0 ? sim->t / sim->scene->t_end : 1;
  double rate = el > 0 ? (double)psteps / el : 0;
  double eta = frac > 0 && sim->step > step0 ? el * (1 - frac) / frac : 0;
  fprintf(stderr, "\rstep %lld  t %.4e s  dt %.3e s  %5.1f%%  ETA %02d:%02d  %.3g particle-steps/s%s",
          (long long)sim->step, sim->t, sim->dt, 100 * frac, (int)(eta / 60), (int)eta % 60, rate, final ? "\n" : "");
  fflush(stderr);
}

/* A stop asked for by ej_sim_request_stop (a signal handler, usually): the signal number, -1, or 0.
 * Written by the handler and read between steps by the main thread only. */
static volatile sig_atomic_t ej_stop_request;

void ej_sim_request_stop(int signo) { ej_stop_request = signo > 0 ? signo : -1; }

int ej_sim_stop_signal(const ej_sim *sim) { return sim ? sim->stop_signal : 0; }

ej_err ej_sim_run(ej_sim *sim)
{
  const ej_scene *sc = sim->scene;
  const double t0 = ej_wall();
  const int64_t step0 = sim->step;
  int64_t n_total = 0, psteps = 0;
  sim->prof_par = 0, sim->prof_out = 0, sim->prof_regions = 0;
  const double t0_prof = sim->profile ? ej_thread_cpu() : 0;
  for (int i = 0; i < sim->n_sets; ++i) n_total += sim->sets[i]->n;
  /* anything may have written the fields before this call (setup, a restart, a test) */
  for (int i = 0; i < sim->n_sets; ++i) sim->sets[i]->ghost_dirty = EJ_ALL_FIELDS;
  ej_err rc = EJ_OK;
  const ej_real eps = 1e-12 * (sc->t_end > 0 ? sc->t_end : 1);
  while (sim->t < sc->t_end - eps && (sc->max_steps <= 0 || sim->step < sc->max_steps)) {
    if (sim->t + sim->dt > sc->t_end) sim->dt = sc->t_end - sim->t; /* land on the end time */
    ej_prof.k = 0, ej_prof.in_step = 1;
    /* first half kick and drift, with the skin watch of the sets that have one in the same
     * region (ej_kick_drift_chunk) */
    bool due = false;
    for (int i = 0; i < sim->n_sets; ++i) {
      ej_set *s = sim->sets[i];
      const bool watch = ej_due_watched(s);
      s->ghost_dirty |= s->step_mask;
      if (watch) EJ_TRY_GOTO(rc, ej_sim_scratch(sim, s), out);
      EJ_TRY_GOTO(rc, ej_for_chunks(sim, s, ej_kick_drift_chunk, (void *)&watch), out);
      if (watch && ej_due_reduce(sim, s)) due = true;
    }
    if (!due) due = ej_due_pairs(sim);
    sim->t += sim->dt;
    sim->step++;
    if (due) EJ_TRY_GOTO(rc, ej_rebuild(sim), out);
    EJ_TRY_GOTO(rc, ej_compute_all(sim, true), out);
    /* Second half kick, then post_step and the diagnostics: in the kick's region when the method
     * says its post_step is local (ej_method_ops.post_step_local) and every interaction's
     * post_step only sums (ej_interaction_ops.post_step_sums_only) (ej_end_chunk); otherwise each
     * in a region of its own, in this order. The interactions' post_steps (serial) come after
     * every set's kick and post_step either way. */
    bool fuse_diag = true;
    for (int k = 0; k < sim->n_inter; ++k)
      if (EJ_HAS_OP(sim->inter[k].ops, ej_interaction_ops, post_step) &&
          !EJ_HAS_OP(sim->inter[k].ops, ej_interaction_ops, post_step_sums_only))
        fuse_diag = false;
    for (int i = 0; i < sim->n_sets; ++i)
      if (sim->sets[i]->mops->post_step && !ej_post_local(sim->sets[i])) fuse_diag = false;
    ej_diag_acc diag;
    ej_diag_init(&diag);
    for (int i = 0; i < sim->n_sets; ++i) {
      ej_set *s = sim->sets[i];
      const ej_end_ctx ec = {.post = ej_post_local(s), .diag = fuse_diag, .with_work = true};
      s->ghost_dirty |= s->step_mask;
      if (ec.post) ej_mark_pass(s, EJ_PASS_POST_STEP);
      if (ec.diag) EJ_TRY_GOTO(rc, ej_sim_scratch(sim, s), out);
      EJ_TRY_GOTO(rc, ej_for_chunks(sim, s, ej_end_chunk, (void *)&ec), out);
      if (ec.diag) ej_diag_add(sim, s, true, &diag);
    }
    for (int i = 0; i < sim->n_sets; ++i)
      if (sim->sets[i]->mops->post_step && !ej_post_local(sim->sets[i])) {
        ej_mark_pass(sim->sets[i], EJ_PASS_POST_STEP);
        EJ_TRY_GOTO(rc, ej_for_chunks(sim, sim->sets[i], ej_post_chunk, NULL), out);
      }
    for (int k = 0; k < sim->n_inter; ++k) {
      ej_inter *in = &sim->inter[k];
      if (EJ_HAS_OP(in->ops, ej_interaction_ops, post_step)) {
        in->a->ghost_dirty |= ej_inter_wmask(in, true, 0, 0);
        if (in->b) in->b->ghost_dirty |= ej_inter_wmask(in, true, 0, 1);
        EJ_TRY_GOTO(rc, in->ops->post_step(in->state, in->a, in->b), out);
      }
    }
    EJ_TRY_GOTO(rc, fuse_diag ? ej_diag_finish(sim, &diag) : ej_diagnostics(sim, true), out);
    const ej_real dt_used = sim->dt;
    EJ_TRY_GOTO(rc, ej_next_dt(sim), out);
    psteps += n_total;
    bool last = !(sim->t < sc->t_end - eps && (sc->max_steps <= 0 || sim->step < sc->max_steps));
    /* The series records the step just taken; checkpoints keep the next step's dt. */
    const ej_real dt_next = sim->dt;
    sim->dt = dt_used;
    const double t_out = sim->profile ? ej_thread_cpu() : 0;
    rc = ej_output_series(sim->out, sim);
    sim->dt = dt_next;
    EJ_TRY_GOTO(rc, rc, out);
    EJ_TRY_GOTO(rc, ej_maybe_output(sim, last), out);
    if (sim->profile) sim->prof_out += ej_thread_cpu() - t_out;
    if (sim->progress) ej_progress(sim, t0, step0, psteps, false);
    /* A stop request (SIGINT / SIGTERM in the CLI) ends the run here, between two steps: the state
     * is whole, and it is kept below as NAME.partial with a last frame and a checkpoint. A request
     * that arrives during the last step is too late to matter: the run is complete. */
    if (ej_stop_request && !last) {
      sim->stop_signal = ej_stop_request;
      ej_stop_request = 0;
      break;
    }
  }
out:
  if (sim->profile && sim->step > step0) {
    /* the serial fraction of the step loop (1 thread: time outside parallel regions / total) */
    const int64_t ns = sim->step - step0;
    sim->prof_loop = ej_thread_cpu() - t0_prof;
    fprintf(stderr,
            "ejecta: profile (CPU time of the main thread): %lld steps, %.4g ms per step, %.4g ms of it in %.3g "
            "parallel regions per step, serial fraction %.4f (output: series and frames %.4f of the step)\n",
            (long long)ns, 1e3 * sim->prof_loop / (double)ns, 1e3 * sim->prof_par / (double)ns,
            (double)sim->prof_regions / (double)ns, 1 - sim->prof_par / sim->prof_loop, sim->prof_out / sim->prof_loop);
    if (ej_prof.level > 1) ej_prof_print(ns, sim->prof_loop, sim->prof_par);
  }
  if (sim->progress) ej_progress(sim, t0, step0, psteps, true);
  /* A numerical failure and a stopped run keep their state (a last frame and a checkpoint) in
   * NAME.partial, from which --restart continues; only a complete run takes the final name. */
  const bool stopped = rc == EJ_OK && sim->stop_signal != 0;
  const bool keep = (rc == EJ_ERR_NUMERIC || stopped) && ej_fail_keep(sim);
  ej_err crc = ej_output_close(sim->out, rc == EJ_OK || keep);
  sim->out = NULL;
  if (keep || stopped) ej_fail_rename(sim, crc, !stopped);
  if (rc == EJ_OK) rc = crc;
  return rc;
}

void ej_sim_destroy(ej_sim *sim)
{
  if (!sim) return;
  if (sim->out) ej_output_close(sim->out, false);
  for (int k = 0; k < sim->n_inter; ++k) {
    if (sim->inter[k].state) sim->inter[k].ops->destroy(sim->inter[k].state);
    ej_nbrlist_destroy(sim->inter[k].list);
    ej_nbrlist_destroy(sim->inter[k].list_ba);
  }
  ej_free(sim->inter);
  for (int i = 0; i < sim->n_sets; ++i) {
    ej_set *s = sim->sets[i];
    if (s->mstate) s->mops->destroy(s->mstate);
    ej_set_destroy(s);
  }
  ej_free(sim->sets);
  ej_models_destroy(sim);
  ej_free(sim->chunk_scratch);
  ej_free(sim->probes);
  ej_free(sim->set_sums);
  ej_free(sim->out_path);
  ej_free(sim);
}
