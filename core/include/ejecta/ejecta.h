/* ejecta application API: load a scene, build a simulation, run it. */
#ifndef EJ_EJECTA_H
#define EJ_EJECTA_H

#include "ejecta/plugin.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EJ_VERSION_STRING EJ_VERSION

typedef struct ej_scene ej_scene;
typedef struct ej_sim ej_sim;

/* A registry with the default plugin search path: the build tree, the install prefix, then
 * the directories of EJECTA_PLUGIN_PATH (colon-separated). */
ej_err ej_registry_create(ej_registry **reg);
void ej_registry_destroy(ej_registry *reg); /* never dlcloses */
/* Replaces the search path (colon-separated directories). */
ej_err ej_registry_set_path(ej_registry *reg, const char *path);

/* Reads and validates a scene. Input errors carry file:line:col. */
ej_err ej_scene_load(const char *path, ej_registry *reg, ej_scene **scene);
void ej_scene_destroy(ej_scene *scene);

typedef struct ej_run_opts {
  size_t struct_size;
  const char *output;  /* overrides the scene's output file, or NULL */
  const char *restart; /* checkpoint file to continue from, or NULL */
  int threads;         /* 0 = OpenMP default */
  bool progress;       /* progress line on stderr */
  ej_real t_end;       /* > 0 overrides the scene's end time */
  bool check_only;     /* validate and build the particles; write nothing, run nothing */
} ej_run_opts;

ej_err ej_sim_create(ej_scene *scene, ej_registry *reg, const ej_run_opts *opts, ej_sim **sim);
/* Runs to the end time; EJ_ERR_NUMERIC when the watchdog stops the run. A run stopped by
 * ej_sim_request_stop returns EJ_OK with ej_sim_stop_signal(sim) != 0: its output is left as
 * NAME.partial (a last frame and a checkpoint at the stop; no XDMF sidecar), which
 * ej_run_opts.restart (the CLI's --restart) continues. */
ej_err ej_sim_run(ej_sim *sim);
/* Asks the running ej_sim_run to stop after its current step. Async-signal-safe (it only sets a
 * flag), so a SIGINT / SIGTERM handler may call it; signo is recorded (<= 0: -1). The request is
 * consumed by the run that honours it. */
void ej_sim_request_stop(int signo);
/* The signal (or -1) whose request stopped the last ej_sim_run of sim before its end; 0 if none. */
int ej_sim_stop_signal(const ej_sim *sim);
void ej_sim_destroy(ej_sim *sim);

/* Prints the current thread's error (one line for input errors) and clears it. */
void ej_error_report(const char *prog);
ej_err ej_error_last_code(void);

#ifdef __cplusplus
}
#endif
#endif
