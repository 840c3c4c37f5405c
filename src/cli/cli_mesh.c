/* packmesh mesh: run one mesher on one input, write the mesh, and optionally its stats
 * (DESIGN.md's JSON keys), the per-iteration trace and snapshots.
 *
 *   packmesh mesh INPUT [--method M] [--size EXPR|NUMBER|inferred] [--set KEY=VALUE ...]
 *                 [--seed N] [--threads N] [--volume] [--target-nodes N]
 *                 [--target-surface-nodes N] [--max-nodes N] -o OUT.(msh|vtk|vtu|stl|obj|mesh) [--stats STATS.json] [--trace TRACE.csv]
 *                 [--frames DIR] [--msh-parametric] [--quiet | --progress]
 *   packmesh mesh --method M --help      the method's parameters, defaults and sources
 *
 * The outputs are one set (pm_outputs, packmesh_extended.h): each is reserved before the run (an unwritable one is
 * reported at once), written under a temporary name, and all are put in place together once
 * every one is complete; on any failure, or SIGINT / SIGTERM (cli_signal.h), none of them
 * exists. Two options naming one file, or an output naming the input, are usage errors.
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include "cli/cli.h"
#include "cli/cli_commands.h"
#include "cli/cli_progress.h"
#include "cli/cli_signal.h"
#include "cli/cli_size.h"
#include "cli/cli_util.h"

#define MAX_SETS 256
/* --target-nodes: runs allowed to bring the node count within TARGET_TOL of the target. */
#define TARGET_RUNS 8
#define TARGET_TOL 0.03

typedef struct mesh_opts {
  const char *input, *method, *size, *out, *stats, *trace, *frames;
  const char *sets[MAX_SETS];
  int nset;
  unsigned long long seed;
  long threads;
  int volume, help, msh_parametric, quiet, progress;
  long target_nodes, max_nodes;
  double time_limit;  /* --time-limit: seconds, 0 for none */
  int target_surface; /* --target-surface-nodes: target_nodes counts the surface nodes */
  int method_given;
} mesh_opts;

/* "bubble, psys": the methods that record a trace and frames. */
static void tracing_names(char *buf, size_t len) {
  buf[0] = '\0';
  for (int i = 0; i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    if (!pm_method_traces(m)) continue;
    strncat(buf, buf[0] ? ", " : "", len - strlen(buf) - 1);
    strncat(buf, pm_method_name(m), len - strlen(buf) - 1);
  }
}

void pm_cli_mesh_usage(FILE *f) {
  char names[512], tracing[512];
  pm_method_names(names, sizeof names);
  tracing_names(tracing, sizeof tracing);
  pm_generate_options defaults;
  pm_generate_options_init(&defaults);
  fprintf(f,
          "usage: packmesh mesh INPUT [--method M] [--size EXPR|NUMBER|inferred] [--set KEY=VALUE ...]\n"
          "                    [--seed N] [--threads N] [--volume] [--target-nodes N]\n"
          "                    [--target-surface-nodes N] [--max-nodes N] [--time-limit SECONDS]\n"
          "                    -o OUT.(msh|vtk|vtu|stl|obj|mesh) [--msh-parametric]\n"
          "                    [--stats STATS.json] [--trace TRACE.csv] [--frames DIR]\n"
          "                    [--quiet | --progress]\n"
          "       packmesh mesh --method M --help\n\n"
          "Meshes INPUT with one method, checks the mesh and writes it to OUT, in the format its\n"
          "extension names. INPUT is a CAD file (" PM_CLI_CAD_EXTENSIONS "), case:NAME (packmesh\n"
          "cases) or a case file (.json).\n"
          "  --method M          the mesher, one of the methods below (default bubble)\n"
          "  --size S            the desired edge length: a number, an expression in x, y, z, r, or\n"
          "                      'inferred' (psys's sizing inference). Without --size the input's own\n"
          "                      size (built-in cases, case files) or the method's default is used.\n"
          "  --set KEY=VALUE     set one of the method's parameters (repeatable); 'packmesh mesh\n"
          "                      --method M --help' lists M's with their defaults, ranges and sources\n"
          "  --seed N            the seed of every random choice (default 1): one seed, one mesh\n"
          "  --threads N         threads, 1 to 1024 (default: OMP_NUM_THREADS, else one per core)\n"
          "  --volume            also mesh the input's volumes with tets (an input without volumes is\n"
          "                      a usage error; 'packmesh cases' gives the cases' dimensions)\n"
          "  --target-nodes N    scale the size field until the node count is within %g%% of N (at\n"
          "                      most %d runs); a miss is a warning on stderr, and target_nodes_met in\n"
          "                      --stats\n"
          "  --target-surface-nodes N\n"
          "                      the same on the surface nodes (the nodes of the triangles): with\n"
          "                      --volume, a volume mesh's interior nodes are not counted\n"
          "  --max-nodes N       the node cap (default %lld): a size field that would need more nodes\n"
          "                      is refused before any method grows\n"
          "  --time-limit S      stop the run once it has lasted S seconds: an error naming where it\n"
          "                      stood, no mesh written (exit 1). The particle methods stop at their\n"
          "                      next iteration, the others between stages; measuring (--stats) is\n"
          "                      not counted\n"
          "  -o, --output OUT    the mesh: .msh, .vtk, .vtu, .stl, .obj or .mesh\n"
          "  --msh-parametric    write each .msh node's parameters on its curve or face (gmsh reads\n"
          "                      them; meshio 7 does not, so they are off by default)\n"
          "  --stats FILE        the run's stats as JSON: counts, validity, quality, distance, times\n"
          "  --trace FILE        the iterations of the run as CSV, a row each (for convergence plots),\n"
          "                      with a row per population control and last the mesh's (column\n"
          "                      event; column nodes ends on the mesh's node count)\n"
          "  --frames DIR        snapshots of the particles during the run: ParaView .vtu files\n"
          "                      indexed by DIR/frames.pvd, and for planar inputs SVG pictures\n"
          "                      (the particles over their triangulation, the phase and the step)\n"
          "                      that 'packmesh animate DIR' turns into a GIF and an HTML player\n"
          "  --quiet             print nothing but errors\n"
          "  --progress          show the progress line (method, phase, iteration, particles,\n"
          "                      the run of a --target-nodes search, elapsed time) into a file\n"
          "                      or pipe too, a line every 2 s; on a terminal it is shown anyway\n"
          "  --help              this text; with --method M, M's parameters\n"
          "--trace and --frames record the iterations of the particle methods (%s); the\n"
          "others record none, and asking them is a usage error.\n"
          "The outputs (-o, --stats, --trace, --frames) are written together or not at all; two of\n"
          "them naming one file is a usage error; SIGINT / SIGTERM leave none (exit 130 / 143).\n"
          "methods: %s (default bubble)\n"
          "'packmesh mesh --method M --help' lists M's parameters (--set KEY=VALUE).\n",
          100 * TARGET_TOL, TARGET_RUNS, (long long)defaults.max_nodes, tracing, names);
}

/* --time-limit: the progress callback of the run, which also draws the progress line, cancels
 * the run once it has lasted the limit, and says where it stood. */
typedef struct run_watch {
  pm_cli_progress *progress;
  double t0, limit; /* limit 0: none */
  int expired;
  char where[160];
} run_watch;

static int watch_report(void *user, const pm_progress *r) {
  run_watch *w = user;
  pm_cli_progress_report(w->progress, r);
  if (!(w->limit > 0) || w->expired || pm_cli_now() - w->t0 <= w->limit) return w->expired;
  w->expired = 1;
  pm_cli_progress_where(r, w->where, sizeof w->where);
  return 1;
}

static int method_help(const pm_method *m) {
  printf("%s: %s\n", pm_method_name(m), pm_method_description(m));
  pm_method_help(m, stdout);
  printf("A number NNN in a SOURCE is the paper papers/NNN: 'packmesh references' cites them.\n");
  return PM_EXIT_OK;
}

static int parse(int argc, char **argv, mesh_opts *o) {
  memset(o, 0, sizeof *o);
  o->method = "bubble";
  o->seed = 1;
  o->threads = omp_get_max_threads();
  pm_generate_options defaults;
  pm_generate_options_init(&defaults);
  o->max_nodes = defaults.max_nodes;
  /* pm_cli_option advances i past an option and its value; every other branch advances it
   * explicitly. */
  for (int i = 1; i < argc;) {
    const char *v = NULL;
    int r;
    const char *a = argv[i];
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      o->help = 1;
      ++i;
      continue;
    }
    if (pm_cli_flag(a, "volume")) {
      o->volume = 1;
      ++i;
      continue;
    }
    if (pm_cli_flag(a, "quiet")) {
      o->quiet = 1;
      ++i;
      continue;
    }
    if (pm_cli_flag(a, "progress")) {
      o->progress = 1;
      ++i;
      continue;
    }
    if (pm_cli_flag(a, "msh-parametric")) {
      o->msh_parametric = 1;
      ++i;
      continue;
    }
    if (strcmp(a, "-o") == 0) {
      if (i + 1 >= argc) return pm_cli_usage("mesh", "-o needs a file name");
      o->out = argv[i + 1];
      i += 2;
      continue;
    }
#define OPT(name, field)                                                         \
  if ((r = pm_cli_option(argc, argv, &i, name, &v)) != 0) {                      \
    if (r < 0) return pm_cli_usage("mesh", "--%s needs a value", name);          \
    field = v;                                                                   \
    continue;                                                                    \
  }
    if ((r = pm_cli_option(argc, argv, &i, "method", &v)) != 0) {
      if (r < 0) return pm_cli_usage("mesh", "--method needs a value");
      o->method = v;
      o->method_given = 1;
      continue;
    }
    OPT("size", o->size)
    OPT("output", o->out)
    OPT("stats", o->stats)
    OPT("trace", o->trace)
    OPT("frames", o->frames)
#undef OPT
    if ((r = pm_cli_option(argc, argv, &i, "set", &v)) != 0) {
      if (r < 0) return pm_cli_usage("mesh", "--set needs KEY=VALUE");
      if (o->nset == MAX_SETS) return pm_cli_usage("mesh", "too many --set options");
      o->sets[o->nset++] = v;
      continue;
    }
    long n;
    if ((r = pm_cli_option(argc, argv, &i, "seed", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 0, 0x7fffffffffffffffL, &n))
        return pm_cli_usage("mesh", "--seed takes a whole number >= 0, got '%s'", v ? v : "");
      o->seed = (unsigned long long)n;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "threads", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 1, 1024, &n))
        return pm_cli_usage("mesh", "--threads takes a whole number from 1 to 1024, got '%s'", v ? v : "");
      o->threads = n;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "target-nodes", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 3, 2000000000L, &n))
        return pm_cli_usage("mesh", "--target-nodes takes a whole number >= 3, got '%s'", v ? v : "");
      if (o->target_nodes && o->target_surface)
        return pm_cli_usage("mesh", "--target-nodes and --target-surface-nodes: give one");
      o->target_nodes = n;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "target-surface-nodes", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 3, 2000000000L, &n))
        return pm_cli_usage("mesh", "--target-surface-nodes takes a whole number >= 3, got '%s'",
                            v ? v : "");
      if (o->target_nodes && !o->target_surface)
        return pm_cli_usage("mesh", "--target-nodes and --target-surface-nodes: give one");
      o->target_nodes = n;
      o->target_surface = 1;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "time-limit", &v)) != 0) {
      double t;
      if (r < 0 || !pm_cli_parse_double(v, &t) || !(t > 0 && t <= 1e9))
        return pm_cli_usage("mesh", "--time-limit takes seconds, a number in (0, 1e9], got '%s'",
                            v ? v : "");
      o->time_limit = t;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "max-nodes", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 3, 2000000000L, &n))
        return pm_cli_usage("mesh", "--max-nodes takes a whole number >= 3, got '%s'", v ? v : "");
      o->max_nodes = n;
      continue;
    }
    if (a[0] == '-' && a[1]) return pm_cli_usage("mesh", "unknown option '%s'", a);
    if (o->input) return pm_cli_usage("mesh", "more than one INPUT ('%s' and '%s')", o->input, a);
    o->input = a;
    ++i;
  }
  return PM_EXIT_OK;
}

int pm_cli_mesh(int argc, char **argv) {
  mesh_opts o;
  int rc = parse(argc, argv, &o);
  if (rc) return rc;
  if (o.help && !o.method_given) {
    pm_cli_mesh_usage(stdout);
    return PM_EXIT_OK;
  }
  const pm_method *method = pm_method_find(o.method);
  if (!method) {
    char names[512];
    pm_method_names(names, sizeof names);
    return pm_cli_usage("mesh", "unknown method '%s' (known: %s)", o.method, names);
  }
  if (o.help) return method_help(method);
  if (o.quiet && o.progress) return pm_cli_usage("mesh", "--quiet and --progress exclude each other");
  if (!o.input) return pm_cli_usage("mesh", "no INPUT given");
  if (!o.out) return pm_cli_usage("mesh", "no output file given (-o OUT.msh)");
  /* An option the method cannot honour is refused rather than written empty. */
  if (!pm_method_traces(method) && (o.trace || o.frames)) {
    char tracing[512];
    tracing_names(tracing, sizeof tracing);
    return pm_cli_usage("mesh", "%s: method %s records no iterations (the methods that do: %s)",
                        o.trace ? "--trace" : "--frames", pm_method_name(method), tracing);
  }
  /* Where the parameters of this method are listed, for the hint of a bad --set. */
  char params_see[160];
  snprintf(params_see, sizeof params_see, "'packmesh mesh --method %s --help' lists the parameters",
           pm_method_name(method));

  pm_error e = {0};
  pm_mesh_format fmt;
  if (pm_mesh_format_of(o.out, &fmt, &e)) return pm_cli_usage("mesh", "%s", e.msg);
  if (o.msh_parametric && fmt != PM_MESH_MSH)
    return pm_cli_usage("mesh", "--msh-parametric applies to .msh output only, not '%s'", o.out);
  /* One file for two outputs would leave only the last one written. */
  const struct {
    const char *opt, *path;
  } outs[4] = {{"-o", o.out}, {"--stats", o.stats}, {"--trace", o.trace}, {"--frames", o.frames}};
  int input_is_file = strncmp(o.input, "case:", 5) != 0;
  for (int i = 0; i < 4; ++i) {
    if (!outs[i].path) continue;
    if (input_is_file && pm_path_same(outs[i].path, o.input))
      return pm_cli_usage("mesh", "%s '%s' names the input file", outs[i].opt, outs[i].path);
    for (int j = i + 1; j < 4; ++j)
      if (outs[j].path && pm_path_same(outs[i].path, outs[j].path))
        return pm_cli_usage("mesh", "%s and %s name the same file '%s'", outs[i].opt, outs[j].opt,
                            outs[j].path);
  }

  /* Parameters: defaults, then --set, then the range check. */
  pm_method_params *params = NULL;
  if (pm_method_params_create(method, &params, &e)) return pm_cli_error(&e);
  for (int k = 0; k < o.nset; ++k)
    if (pm_method_params_set_pair(params, o.sets[k], &e)) {
      pm_method_params_destroy(params);
      return pm_cli_usage_see(params_see, "%s", e.msg);
    }
  if (pm_method_params_check(params, &e)) {
    pm_method_params_destroy(params);
    return pm_cli_usage_see(params_see, "%s", e.msg);
  }
  /* --size is read before any file is: text that is neither a number, an expression nor
   * 'inferred' is a usage error; a field that fails on the input is a failure (below). */
  pm_sizing *parsed_size = NULL;
  if (o.size && pm_cli_size_parse(o.size, &parsed_size, &e)) {
    pm_method_params_destroy(params);
    return pm_cli_usage("mesh", "%s", e.msg);
  }

  /* Every output reserved before the run; written under these names, renamed at the end. */
  pm_cli_signals_detail("; nothing was written");
  pm_outputs *outputs = pm_outputs_create();
  const char *tmp[4] = {NULL, NULL, NULL, NULL};
  if (!outputs) {
    pm_sizing_destroy(parsed_size);
    pm_method_params_destroy(params);
    return pm_cli_fail("out of memory");
  }
  for (int i = 0; i < 4; ++i)
    if (outs[i].path && pm_outputs_add(outputs, outs[i].path, i == 3, &tmp[i], &e)) {
      pm_outputs_destroy(outputs);
      pm_sizing_destroy(parsed_size);
      pm_method_params_destroy(params);
      return pm_cli_error(&e);
    }

  omp_set_num_threads((int)o.threads);
  double t_start = pm_cli_now();
  pm_model *model = NULL;
  pm_sizing *input_size = NULL, *size = NULL, *scaled = NULL;
  pm_report *report = NULL;
  pm_mesh *out_mesh = NULL;
  /* A usage error found once the input is open (an option that does not apply to it): the same
   * clean-up as a failure, exit 2. */
  int usage = 0;
  pm_cli_progress progress;
  pm_cli_progress_init(&progress, o.quiet ? PM_PROGRESS_OFF : o.progress ? PM_PROGRESS_ON : PM_PROGRESS_AUTO,
                       pm_method_name(method));
  pm_cli_progress_stage(&progress, "loading the input");
  pm_status s = pm_model_open(o.input, &model, &input_size, &e);
  if (s) goto fail;
  const char *heal = pm_model_healed(model);
  if (heal[0] && !o.quiet) {
    pm_cli_progress_done(&progress);
    fprintf(stderr, "packmesh: %s: healed: %s\n", o.input, heal);
  }
  /* The size field: --size, else the input's own, else the method's default (NULL). */
  if (o.size) {
    s = pm_cli_size_resolve(parsed_size, method, model, o.seed, (int)o.threads, &size, &e);
    parsed_size = NULL;
    if (s) goto fail;
  } else {
    size = input_size, input_size = NULL;
  }
  pm_generate_options go;
  pm_generate_options_init(&go);
  go.seed = o.seed;
  go.threads = (int)o.threads;
  go.volume = o.volume;
  go.max_nodes = o.max_nodes;
  go.target_nodes = o.target_nodes;
  go.target_surface = o.target_surface;
  go.target_tolerance = TARGET_TOL;
  go.target_runs = TARGET_RUNS;
  run_watch watch = {&progress, pm_cli_now(), o.time_limit, 0, ""};
  if (progress.active || o.time_limit > 0) go.progress = watch_report, go.progress_user = &watch;
  if (go.target_nodes > 0) progress.runs = go.target_runs;
  /* An option that does not fit the input is a usage error, named by its option. */
  pm_generate_misfit misfit;
  if ((s = pm_generate_check(model, size, method, &go, &misfit, &e))) {
    if (misfit == PM_MISFIT_VOLUME) pm_error_prefix(&e, "--volume");
    if (misfit == PM_MISFIT_TARGET)
      pm_error_setf(&e, PM_ERR_ARG,
                    "--target-%snodes needs --size for method %s (it has no default field to "
                    "scale)",
                    o.target_surface ? "surface-" : "", pm_method_name(method));
    usage = misfit != PM_MISFIT_NONE;
    goto fail;
  }

  if ((s = pm_report_create(pm_method_name(method), o.input, &report, &e)) ||
      (o.trace && (s = pm_report_record_trace(report, &e))) ||
      (o.frames && (s = pm_report_record_frames(report, tmp[3], model, &e))))
    goto fail;
  pm_generate_result result;
  s = pm_generate_report(model, size, method, params, &go, report, &scaled, &out_mesh, &result, &e);
  if (s == PM_ERR_CANCELLED && watch.expired)
    s = pm_error_setf(&e, PM_ERR_LIMIT, "%s: %s stopped at the time limit of %g s (%s); no mesh "
                      "written", o.input, pm_method_name(method), o.time_limit, watch.where);
  if (s) goto fail;
  const pm_sizing *final_size = scaled ? scaled : size;
  double t_run = pm_cli_now() - t_start;

  /* Stats: the verdict of the checker, the quality module, the distance to the model, each
   * measuring stage timed beside the method's own phases. */
  if (o.stats) {
    pm_cli_progress_stage(&progress, "measuring the mesh");
    if ((s = pm_report_measure(report, out_mesh, model, final_size, PM_REPORT_ALL, &e)) ||
        (s = pm_report_set_time(report, "total", t_run, &e)) ||
        (s = pm_report_record_run(report, model, method, params, &go, &result, final_size, &e)))
      goto fail;
  }

  /* Files: the mesh, the stats, the trace and the frames' index under their temporary names,
   * then all of them into place. Messages name the destinations, not the temporaries. */
  pm_cli_progress_stage(&progress, "writing");
  pm_mesh_write_opts wopts = {0};
  wopts.msh_parametric = o.msh_parametric;
  if ((s = pm_mesh_write_with(out_mesh, tmp[0], &wopts, &e)) ||
      (o.stats && (s = pm_report_write_stats(report, tmp[1], &e))) ||
      (o.trace && (s = pm_report_write_trace(report, tmp[2], &e))) ||
      (s = pm_report_finish_frames(report, &e)))
    goto fail;
  if ((s = pm_outputs_commit(outputs, &e))) goto fail;

  pm_cli_progress_done(&progress);
  /* A format that cannot hold an element kind leaves it out: said in one line, not silently. */
  if (!o.quiet) {
    int32_t count[4] = {0};
    for (int d = 1; d <= 3; ++d) count[d] = pm_mesh_element_count(out_mesh, d);
    static const char *const kind[4] = {"", "segments", "triangles", "tets"};
    char left[160] = "";
    for (int d = 1; d <= 3; ++d)
      if (count[d] > 0 && !pm_mesh_format_holds(fmt, d))
        snprintf(left + strlen(left), sizeof left - strlen(left), "%s%d %s",
                 left[0] ? " and " : "", (int)count[d], kind[d]);
    if (left[0])
      fprintf(stderr,
              "packmesh: warning: a .%s file cannot hold %s; they are not in %s (.msh, .vtu, "
              ".vtk and .mesh hold every kind)\n",
              pm_mesh_format_ext(fmt), left, o.out);
  }
  /* A missed target is a result, not a failure: the mesh of the last run is written; the line says
   * by how much it missed (a domain's corners alone may be more nodes than asked for, a cap or
   * the method's stopping rule may keep it from getting closer). */
  const int32_t nodes = pm_mesh_node_count(out_mesh);
  if (o.target_nodes && !result.target_met && !o.quiet)
    fprintf(stderr,
            "packmesh: warning: --target-%snodes %ld missed: %lld %snodes after %d runs (%+.1f%%; "
            "the tolerance is %g%%)\n",
            o.target_surface ? "surface-" : "", o.target_nodes, (long long)result.target_count,
            o.target_surface ? "surface " : "", result.runs,
            100.0 * ((double)result.target_count / (double)o.target_nodes - 1), 100 * TARGET_TOL);
  if (!o.quiet)
    printf("%s %s: %d nodes, %d segments, %d triangles, %d tets in %.2f s (%s) -> %s\n",
           pm_method_name(method), o.input, (int)nodes, (int)pm_mesh_element_count(out_mesh, 1),
           (int)pm_mesh_element_count(out_mesh, 2), (int)pm_mesh_element_count(out_mesh, 3),
           t_run, result.stop_reason[0] ? result.stop_reason : "done", o.out);
  rc = PM_EXIT_OK;
  goto done;
fail:
  /* Messages name the destinations, not their temporary names. */
  for (int i = 0; i < 4; ++i)
    if (tmp[i]) {
      char *at = strstr(e.msg, tmp[i]);
      if (!at) continue;
      char rest[sizeof e.msg];
      snprintf(rest, sizeof rest, "%s", at + strlen(tmp[i]));
      snprintf(at, sizeof e.msg - (size_t)(at - e.msg), "%s%s", outs[i].path, rest);
    }
  pm_cli_progress_done(&progress);
  rc = usage ? pm_cli_usage("mesh", "%s", e.msg) : pm_cli_error(&e);
done:
  pm_outputs_destroy(outputs);
  pm_report_destroy(report);
  pm_mesh_destroy(out_mesh);
  pm_sizing_destroy(scaled);
  pm_sizing_destroy(size);
  pm_sizing_destroy(input_size);
  pm_sizing_destroy(parsed_size);
  pm_model_destroy(model);
  pm_method_params_destroy(params);
  return rc;
}
