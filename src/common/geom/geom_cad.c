/* Loading CAD files through gmsh (see geom_cad.h): file checks, the import into a fresh gmsh
 * model, the error mapping, the model-current guard used by every gmsh call of the backend, and
 * the model's release. Building the cell complex is geom_cad_build.c.
 */
#include "common/geom/geom_cad.h"

#include <gmshc.h>

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/geom/cad_declared.h"
#include "common/base/clock.h"
#include "common/geom/geom_cad_heal.h"
#include "common/geom/geom_cad_private.h"
#include "common/backends/gmsh_session.h"

/* ---- the model-current guard ------------------------------------------------------------- */

/* gmshModelGetCurrent + strcmp cost about 25 ns, a switch about 35 ns more (measured on the
 * 2-core test machine), against 100-600 ns for the gmsh evaluation itself; a full
 * pm_gmsh_scope (which lists all models) would cost more than the evaluation. */
int cad_enter(const cad_model *cm, cad_guard *g) {
  pm_gmsh_lock();
  g->switched = 0;
  g->previous[0] = '\0';
  char *cur = NULL;
  int ierr = 0;
  gmshModelGetCurrent(&cur, &ierr);
  if (!ierr && cur && strcmp(cur, cm->gname) == 0) {
    gmshFree(cur);
    return 0;
  }
  if (!ierr && cur) snprintf(g->previous, sizeof g->previous, "%s", cur);
  if (cur) gmshFree(cur);
  ierr = 0;
  gmshModelSetCurrent(cm->gname, &ierr);
  /* gmsh 4.8.4 reports an unknown name only in its log (ierr stays 0) and leaves the current
   * model as it was: check. When our model is gone (removed behind our back) the caller must not
   * call gmsh, which would act on whatever model is current. */
  cur = NULL;
  gmshModelGetCurrent(&cur, &ierr);
  int ours = !ierr && cur && strcmp(cur, cm->gname) == 0;
  if (cur) gmshFree(cur);
  if (!ours) return -1;
  g->switched = 1;
  return 0;
}

void cad_leave(cad_guard *g) {
  /* gmsh's unnamed default model ("") cannot be selected by name: it is left as is. */
  if (g->switched && g->previous[0]) {
    int ierr = 0;
    gmshModelSetCurrent(g->previous, &ierr);
  }
  pm_gmsh_unlock();
}

/* ---- model lifecycle --------------------------------------------------------------------- */

static void cad_destroy_impl(pm_model *m) {
  cad_model *cm = m->impl;
  if (!cm) return;
  if (cm->gname[0]) {
    cad_guard g;
    if (cad_enter(cm, &g) == 0) {
      int ierr = 0;
      gmshModelRemove(&ierr);
    }
    cad_leave(&g);
  }
  for (int d = 0; d < 4; ++d) {
    for (int32_t i = 0; cm->cells[d] && i < m->count[d]; ++i)
      free(cm->cells[d][i].grid), free(cm->cells[d][i].reproj);
    free(cm->cells[d]);
  }
  free(cm);
  m->impl = NULL;
}

pm_status cad_attach(pm_model *m, const char *gname, pm_error *err) {
  cad_model *cm = calloc(1, sizeof *cm);
  if (!cm) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  snprintf(cm->gname, sizeof cm->gname, "%s", gname);
  atomic_init(&cm->failures, 0);
  m->impl = cm;
  m->destroy_impl = cad_destroy_impl;
  for (int d = 0; d < 4; ++d) {
    if (m->count[d] == 0) continue;
    cm->cells[d] = calloc((size_t)m->count[d], sizeof(cad_cell));
    if (!cm->cells[d]) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    for (int32_t i = 0; i < m->count[d]; ++i) {
      cm->cells[d][i].cm = cm;
      m->cells[d][i].impl = &cm->cells[d][i];
    }
  }
  return PM_OK;
}

static int is_cad_model(const pm_model *m) {
  return m && m->destroy_impl == cad_destroy_impl && m->impl;
}

long pm_cad_eval_failures(const pm_model *m) {
  if (!is_cad_model(m)) return -1;
  return atomic_load(&((cad_model *)m->impl)->failures);
}

int pm_cad_cell_is_fast(const pm_cell *c) {
  if (!c || !is_cad_model(c->model) || !c->impl) return -1;
  return ((const cad_cell *)c->impl)->form.kind != CAD_GMSH;
}

const char *pm_cad_gmsh_model(const pm_model *m) {
  if (!is_cad_model(m)) return NULL;
  return ((const cad_model *)m->impl)->gname;
}

pm_status cad_new_gmsh_model(char name[64], pm_gmsh_scope *scope, pm_error *err) {
  /* Unique for the process: a counter (under the gmsh lock held by the caller) plus a check
   * against models that already exist under that name. */
  static unsigned long serial = 0;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    snprintf(name, 64, "pm_cad_%lu", ++serial);
    pm_error e = {0};
    pm_status s = pm_gmsh_scope_enter(scope, name, 1, &e);
    if (s == PM_OK) return PM_OK;
    if (s != PM_ERR_INTERNAL) {
      if (err) *err = e;
      return s;
    }
  }
  return pm_error_setf(err, PM_ERR_BACKEND, "could not create a uniquely named gmsh model");
}

/* ---- building and loading ----------------------------------------------------------------- */

int pm_cad_occ_cut_volumes(int object, int tool) {
  int ierr = 0, obj[2] = {3, object}, tl[2] = {3, tool};
  int *out = NULL, **map = NULL;
  size_t nout = 0, *nmap = NULL, nnmap = 0;
  gmshModelOccCut(obj, 2, tl, 2, &out, &nout, &map, &nmap, &nnmap, -1, 1, 1, &ierr);
  if (out) gmshFree(out);
  for (size_t i = 0; i < nnmap; ++i) gmshFree(map[i]);
  if (map) gmshFree(map);
  if (nmap) gmshFree(nmap);
  return ierr;
}

pm_status pm_cad_build_shapes(const char *label, int (*make)(void), pm_model **out, pm_error *err) {
  *out = NULL;
  pm_status s = pm_gmsh_begin(err);
  if (s) return s;
  pm_gmsh_lock();
  pm_gmsh_scope scope;
  char gname[64];
  s = cad_new_gmsh_model(gname, &scope, err);
  if (s) {
    pm_gmsh_unlock();
    return s;
  }
  int ierr = make();
  if (!ierr) gmshModelOccSynchronize(&ierr);
  if (ierr) {
    s = pm_gmsh_error(err, PM_ERR_BACKEND, "building the shape");
    pm_gmsh_scope_leave(&scope, 1);
    pm_gmsh_unlock();
    return s;
  }
  pm_model *m = NULL;
  s = cad_build(gname, label, &m, err);
  pm_gmsh_scope_leave(&scope, 0);
  pm_gmsh_unlock();
  if (s) return s;
  *out = m;
  return PM_OK;
}

typedef enum cad_format { FMT_NONE = 0, FMT_STEP, FMT_IGES, FMT_BREP } cad_format;

static cad_format format_of(const char *path, const char **ext) {
  const char *slash = strrchr(path, '/');
  const char *dot = strrchr(slash ? slash + 1 : path, '.');
  *ext = dot ? dot : "";
  if (!dot) return FMT_NONE;
  char low[8];
  size_t n = strlen(dot + 1);
  if (n == 0 || n >= sizeof low) return FMT_NONE;
  for (size_t i = 0; i <= n; ++i) low[i] = (char)tolower((unsigned char)dot[1 + i]);
  if (!strcmp(low, "step") || !strcmp(low, "stp")) return FMT_STEP;
  if (!strcmp(low, "iges") || !strcmp(low, "igs")) return FMT_IGES;
  if (!strcmp(low, "brep")) return FMT_BREP;
  return FMT_NONE;
}

/* Does the file start like a file of its format? Used to tell a corrupt file (PM_ERR_PARSE)
 * from a well-formed file without shapes (PM_ERR_GEOM) when gmsh imports nothing, because gmsh
 * 4.8.4 reports no error for an unreadable BREP or IGES file. */
static int has_signature(const char *path, cad_format fmt) {
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  char buf[200];
  size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = '\0';
  /* Skip leading blanks. */
  size_t i = 0;
  while (i < n && isspace((unsigned char)buf[i])) ++i;
  const char *s = buf + i;
  switch (fmt) {
    case FMT_STEP: return strncmp(s, "ISO-10303-21", 12) == 0;
    case FMT_BREP:
      return strncmp(s, "DBRep_DrawableShape", 19) == 0 || strncmp(s, "CASCADE Topology", 16) == 0;
    case FMT_IGES: {
      /* Fixed 80-column records; the first is a start record, 'S' in column 73. */
      const char *nl = strchr(buf, '\n');
      size_t len = nl ? (size_t)(nl - buf) : n;
      if (len > 0 && buf[len - 1] == '\r') --len;
      return len >= 73 && buf[72] == 'S';
    }
    default: return 0;
  }
}

/* The first error gmsh logged, or "" (gmsh 4.8.4 reports a failed STEP read only there: the
 * import itself returns ierr = 0 with no entities). */
static void first_logged_error(char *out, size_t len) {
  out[0] = '\0';
  char **log = NULL;
  size_t n = 0;
  int ierr = 0;
  gmshLoggerGet(&log, &n, &ierr);
  for (size_t i = 0; i < n; ++i) {
    if (!out[0] && log[i] && strncmp(log[i], "Error", 5) == 0) {
      const char *msg = log[i] + 5;
      while (*msg == ':' || *msg == ' ') ++msg;
      snprintf(out, len, "%s", msg);
    }
    gmshFree(log[i]);
  }
  if (log) gmshFree(log);
}

/* Import `path` into the current gmsh model, with Geometry.OCCSewFaces set to `sew` for the
 * import, and synchronize when `sync`. Returns 0, or 1 when gmsh failed (logged: its first logged error, or ""
 * -- gmsh 4.8.4 reports a failed STEP read only in its log). */
static int import_shapes(const char *path, cad_format fmt, int sew, int sync, char *logged,
                         size_t len) {
  int ierr = 0;
  double sew_before = 0;
  gmshOptionGetNumber("Geometry.OCCSewFaces", &sew_before, &ierr);
  gmshOptionSetNumber("Geometry.OCCSewFaces", sew, &ierr);
  /* gmsh's logger records messages only at verbosity >= 1 (gmsh_session sets 0); with
   * General.Terminal = 0 nothing is printed either way. */
  double verbosity = 0;
  gmshOptionGetNumber("General.Verbosity", &verbosity, &ierr);
  if (verbosity < 1) gmshOptionSetNumber("General.Verbosity", 1, &ierr);
  gmshLoggerStart(&ierr);
  int token = pm_gmsh_mute_stdout(); /* OCC prints transfer statistics on stdout */
  int *dt = NULL;
  size_t ndt = 0;
  ierr = 0;
  gmshModelOccImportShapes(path, &dt, &ndt, 0,
                           fmt == FMT_STEP ? "step" : (fmt == FMT_IGES ? "iges" : "brep"), &ierr);
  int import_err = ierr;
  if (dt) gmshFree(dt);
  ierr = 0;
  if (!import_err && sync) gmshModelOccSynchronize(&ierr);
  int sync_err = ierr;
  pm_gmsh_unmute_stdout(token);
  first_logged_error(logged, len);
  gmshLoggerStop(&ierr);
  gmshOptionSetNumber("General.Verbosity", verbosity, &ierr);
  gmshOptionSetNumber("Geometry.OCCSewFaces", sew_before, &ierr);
  return import_err || sync_err;
}

static pm_status heal_error(pm_error *err, const char *path, const char *what) {
  pm_gmsh_error(err, PM_ERR_BACKEND, what);
  return pm_error_prefix(err, "%s", path);
}

/* Replace the current gmsh model by an empty one of the same name, so that a second import
 * numbers its shapes as gmsh would number them in a fresh model. Removing the shapes instead
 * (gmshModelOccRemove) keeps gmsh 4.8.4's entity objects allocated: GModel::remove takes them
 * out of the model without deleting them, where removing the model deletes them. */
static int clear_current_model(void) {
  char *name = NULL;
  int ierr = 0;
  gmshModelGetCurrent(&name, &ierr);
  if (ierr || !name) return -1;
  char copy[64];
  snprintf(copy, sizeof copy, "%s", name);
  gmshFree(name);
  gmshModelRemove(&ierr);
  if (!ierr) gmshModelAdd(copy, &ierr);
  return ierr ? -1 : 0;
}

/* Measure the imported model and heal it where the measurement says so (geom_cad_heal.c);
 * `healed` receives the report, "" when nothing was done. An IGES file with coincident
 * vertices is imported again with Geometry.OCCSewFaces = 1: IGES faces arrive unsewn, with gaps
 * up to 1e-4 of the diagonal between their edges (bearing.iges: 450 of 475 edges shared after
 * sewing on import), more than the in-place sewing's tolerance closes. An IGES file without
 * (statreport/sphere_Rhino3D_default.igs, one face) is left alone: sewing it replaces the
 * sphere's seam and poles and gmsh then fails to mesh it ("Impossible to mesh periodic
 * surface"). */
static int synchronize(void) {
  int ierr = 0;
  gmshModelOccSynchronize(&ierr);
  return ierr ? -1 : 0;
}

/* The file imported again into an empty model, not synchronized. */
static int import_again(const char *path, cad_format fmt, int sew) {
  char logged[256];
  return clear_current_model() || import_shapes(path, fmt, sew, 0, logged, sizeof logged) ? -1
                                                                                           : 0;
}

static pm_status heal(const char *path, cad_format fmt, char *healed, size_t len, pm_error *err) {
  healed[0] = '\0';
  cad_heal_counts before, after;
  if (cad_heal_count(&before))
    return heal_error(err, path, "measuring the model");
  cad_heal_action act = cad_heal_choose(&before);
  if (act == CAD_HEAL_NONE) return PM_OK;
  const char *how;
  if (fmt == FMT_IGES) {
    if (import_again(path, fmt, 1) || synchronize())
      return heal_error(err, path, "sewing the IGES faces");
    how = "imported again with the faces sewn (gmsh's Geometry.OCCSewFaces)";
  } else if (act == CAD_HEAL_SEW) {
    /* Imported again rather than sewn where the measurement's import lies: synchronizing a model
     * whose shapes were replaced leaks gmsh 4.8.4's old entities (ASan: OCC_Internals::
     * synchronize), removing the model deletes them. It costs an import and, where pairs are
     * left, a second sewing (step__mesh_T106_V3.step: two imports of 0.075 s and a sewing of
     * 0.03 s beside the fragment's 1.1 s); sewing in place gave the same meshes to the byte. */
    if (import_again(path, fmt, 0) || cad_heal_sew() || synchronize())
      return heal_error(err, path, "sewing the faces");
    how = "sewed the faces (OpenCASCADE's BRepBuilderAPI_Sewing, gmsh's Geometry.OCCSewFaces)";
    /* Sewing leaves pairs whose faces do not meet along a whole edge (T-junctions: a vertex of
     * one face inside an edge of the other); fragmenting merges those. */
    cad_heal_counts sewn;
    if (cad_heal_count(&sewn)) return heal_error(err, path, "measuring the sewn model");
    if (sewn.coincident > 0) {
      if (import_again(path, fmt, 0) || cad_heal_sew() || cad_heal_fragment() || synchronize())
        return heal_error(err, path, "merging the sewn faces");
      how = "sewed the faces (OpenCASCADE's BRepBuilderAPI_Sewing, gmsh's Geometry.OCCSewFaces) "
            "and merged what sewing left (gmsh's RemoveAllDuplicates)";
    }
  } else if (act == CAD_HEAL_TWINS) {
    cad_twin_plan plan;
    if (cad_heal_plan_twins(&plan)) return heal_error(err, path, "finding the faces listed twice");
    int failed = import_again(path, fmt, 0) || cad_heal_drop_twins(&plan) || synchronize();
    cad_twin_plan_free(&plan);
    if (failed) return heal_error(err, path, "removing faces listed twice");
    how = "removed the repeats and rebuilt the volumes that listed them";
  } else {
    if (import_again(path, fmt, 0) || cad_heal_fragment() || synchronize())
      return heal_error(err, path, "merging the touching solids");
    how = "merged the shapes that touch (gmsh's RemoveAllDuplicates)";
  }
  if (cad_heal_count(&after))
    return heal_error(err, path, "measuring the healed model");
  cad_heal_describe(&before, &after, how, healed, len);
  return PM_OK;
}

pm_status pm_cad_load(const char *path, pm_model **out, pm_error *err) {
  *out = NULL;
  if (!path || !path[0]) return pm_error_setf(err, PM_ERR_ARG, "no CAD file name given");
  const char *ext;
  cad_format fmt = format_of(path, &ext);
  if (fmt == FMT_NONE)
    return pm_error_setf(err, PM_ERR_ARG,
                         "%s: unknown CAD file extension '%s' (expected .step, .stp, .iges, "
                         ".igs or .brep)",
                         path, ext);
  struct stat st;
  if (stat(path, &st) != 0)
    return pm_error_setf(err, PM_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
  if (!S_ISREG(st.st_mode)) return pm_error_setf(err, PM_ERR_IO, "%s: not a regular file", path);
  FILE *probe = fopen(path, "rb");
  if (!probe) return pm_error_setf(err, PM_ERR_IO, "%s: cannot read: %s", path, strerror(errno));
  fclose(probe);
  if (st.st_size == 0) return pm_error_setf(err, PM_ERR_PARSE, "%s: the file is empty", path);
  /* A truncated or damaged file is refused by what it declares (cad_declared.h). */
  pm_status declared = pm_cad_check_declared(path, err);
  if (declared) return declared;

  pm_status s = pm_gmsh_begin(err);
  if (s) return pm_error_prefix(err, "%s", path);

  pm_gmsh_lock();
  pm_gmsh_scope scope;
  char gname[64];
  s = cad_new_gmsh_model(gname, &scope, err);
  if (s) {
    pm_gmsh_unlock();
    return pm_error_prefix(err, "%s", path);
  }
  char logged[256];
  int import_err = import_shapes(path, fmt, 0, 1, logged, sizeof logged);
  if (import_err) {
    s = logged[0] ? pm_error_setf(err, PM_ERR_PARSE, "%s: gmsh cannot import it: %s", path, logged)
                  : pm_error_setf(err, PM_ERR_PARSE, "%s: gmsh cannot import it", path);
    pm_gmsh_scope_leave(&scope, 1);
    pm_gmsh_unlock();
    return s;
  }
  int ierr = 0;
  int *dt = NULL;
  size_t nent = 0;
  dt = NULL;
  gmshModelGetEntities(&dt, &nent, -1, &ierr);
  if (dt) gmshFree(dt);
  if (nent == 0) {
    if (logged[0] || !has_signature(path, fmt))
      s = pm_error_setf(err, PM_ERR_PARSE,
                        "%s: cannot parse the file (corrupt, truncated or not %s)%s%s", path,
                        fmt == FMT_STEP ? "STEP" : (fmt == FMT_IGES ? "IGES" : "an OCCT BREP file"),
                        logged[0] ? ": " : "", logged);
    else
      s = pm_error_setf(err, PM_ERR_GEOM, "%s: the file imports to an empty model (no shapes)",
                        path);
    pm_gmsh_scope_leave(&scope, 1);
    pm_gmsh_unlock();
    return s;
  }

  char healed[384];
  s = heal(path, fmt, healed, sizeof healed, err);
  if (s) {
    pm_gmsh_scope_leave(&scope, 1);
    pm_gmsh_unlock();
    return s;
  }
  pm_model *m = NULL;
  double t0 = pm_seconds();
  s = cad_build(gname, path, &m, err);
  if (!s) {
    const cad_model *cm = m->impl;
    if (cm->reprojected > 0)
      snprintf(m->heal, sizeof m->heal, "%s%sboundary curves whose pcurve strays from the curve "
               "(by up to %.3g), taken by projection onto the face: %d",
               healed, healed[0] ? "; " : "", cm->reproj_worst, (int)cm->reprojected);
    else
      snprintf(m->heal, sizeof m->heal, "%s", healed);
    m->time_build = pm_seconds() - t0;
  }
  /* On failure cad_build released the model, which removed the gmsh model. */
  pm_gmsh_scope_leave(&scope, 0);
  pm_gmsh_unlock();
  if (s) return pm_error_prefix(err, "%s", path);
  *out = m;
  return PM_OK;
}
