/* The mesh formats gmsh writes (.msh, .stl, .mesh): see mesh_io.h for the conventions.
 *
 * gmsh error reporting: with General.AbortOnError = 0 (gmsh_session.c), gmsh 4.8.4 reports most
 * failures of gmshWrite (an unknown output format, an unwritable file) only through its "last
 * error" message, with ierr left at 0. So before each such call a sentinel error is logged, and
 * the call failed when the last error is no longer the sentinel.
 */
#include "common/mesh/mesh_io_gmsh.h"

#include <gmshc.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/backends/gmsh_session.h"
#include "common/mesh/element_measure.h"

/* ---- gmsh helpers ------------------------------------------------------------------------- */

#define SENTINEL "packmesh: no error since the last call"

static void gm_mark(void) {
  int ierr = 0;
  gmshLoggerWrite(SENTINEL, "error", &ierr);
}

/* 1 when gmsh reported an error since gm_mark() (or ierr is set); the message goes to msg. */
static int gm_failed(int ierr, char *msg, size_t len) {
  char *e = NULL;
  int ie = 0;
  gmshLoggerGetLastError(&e, &ie);
  int failed = ierr != 0 || (e && strcmp(e, SENTINEL) != 0);
  if (failed) snprintf(msg, len, "%s", (e && strcmp(e, SENTINEL) != 0) ? e : "gmsh failed");
  if (e) gmshFree(e);
  return failed;
}

typedef struct gm_option {
  const char *name;
  double value, saved;
} gm_option;

static void options_set(gm_option *o, int n) {
  int ierr = 0;
  for (int i = 0; i < n; ++i) {
    o[i].saved = 0;
    gmshOptionGetNumber(o[i].name, &o[i].saved, &ierr);
    gmshOptionSetNumber(o[i].name, o[i].value, &ierr);
  }
}

static void options_restore(gm_option *o, int n) {
  int ierr = 0;
  for (int i = n - 1; i >= 0; --i) gmshOptionSetNumber(o[i].name, o[i].saved, &ierr);
}

static unsigned long scope_counter = 0; /* guarded by the gmsh lock */

/* ---- writing through gmsh ----------------------------------------------------------------- */

typedef struct ent_key {
  int dim, tag;
  int32_t idx;
} ent_key;

static int cmp_ent_key(const void *pa, const void *pb) {
  const ent_key *a = pa, *b = pb;
  if (a->dim != b->dim) return a->dim - b->dim;
  if (a->tag != b->tag) return (a->tag > b->tag) - (a->tag < b->tag);
  return (a->idx > b->idx) - (a->idx < b->idx);
}

static int cell_tag(int32_t cell) { return cell >= 0 ? cell + 1 : PM_MSH_UNTAGGED; }

/* The elements in the order gmsh writes them: by dimension, entity tag, then index (ek holds
 * nseg + ntri + ntet keys). Returns their number. */
static size_t element_order(const pm_mesh *m, ent_key *ek) {
  size_t ne = 0;
  for (int32_t i = 0; i < m->nseg; ++i) ek[ne++] = (ent_key){1, cell_tag(m->seg_cell[i]), i};
  for (int32_t i = 0; i < m->ntri; ++i) ek[ne++] = (ent_key){2, cell_tag(m->tri_cell[i]), i};
  for (int32_t i = 0; i < m->ntet; ++i) ek[ne++] = (ent_key){3, cell_tag(m->tet_cell[i]), i};
  qsort(ek, ne, sizeof *ek, cmp_ent_key);
  return ne;
}

/* Build the mesh as discrete entities of the current gmsh model. gmsh's Medit and STL writers
 * number nodes entity by entity; so that node i of the mesh stays point i of the file, those
 * formats get every node on one entity (they store no node classification anyway). */
static pm_status gmsh_build(const pm_mesh *m, int classify, int parametric, pm_error *err) {
  int topdim = m->ntet ? 3 : m->ntri ? 2 : m->nseg ? 1 : 0;
  size_t nn = (size_t)m->nnode;
  size_t nelem = (size_t)m->nseg + (size_t)m->ntri + (size_t)m->ntet;
  ent_key *nk = malloc((nn ? nn : 1) * sizeof *nk);
  ent_key *ek = malloc((nelem ? nelem : 1) * sizeof *ek);
  ent_key *ents = malloc((nn + nelem + 1) * sizeof *ents);
  /* One entity's block of elements needs an element tag and up to 4 node tags each (tets): 5 per
   * element; the node pass needs one per node. */
  size_t *tags = malloc((nn > nelem ? nn : nelem) * 5 * sizeof *tags + sizeof *tags);
  double *xyz = malloc((nn ? nn : 1) * 3 * sizeof *xyz);
  double *par = malloc((nn ? nn : 1) * 2 * sizeof *par);
  pm_status s = PM_OK;
  if (!nk || !ek || !ents || !tags || !xyz || !par) {
    s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory writing a mesh");
    goto done;
  }
  for (size_t v = 0; v < nn; ++v) {
    int d = m->node_dim[v];
    if (classify && d >= 0 && d <= 3 && m->node_cell[v] >= 0)
      nk[v] = (ent_key){d, m->node_cell[v] + 1, (int32_t)v};
    else
      nk[v] = (ent_key){topdim, PM_MSH_UNTAGGED, (int32_t)v};
  }
  size_t ne = element_order(m, ek);
  qsort(nk, nn, sizeof *nk, cmp_ent_key);

  /* Entities: every (dim, tag) used by a node or an element, created once. */
  size_t nent = 0;
  for (size_t i = 0; i < nn; ++i) ents[nent++] = (ent_key){nk[i].dim, nk[i].tag, 0};
  for (size_t i = 0; i < ne; ++i) ents[nent++] = (ent_key){ek[i].dim, ek[i].tag, 0};
  qsort(ents, nent, sizeof *ents, cmp_ent_key);
  int ierr = 0;
  char msg[400];
  gm_mark();
  for (size_t i = 0; i < nent; ++i) {
    if (i > 0 && ents[i].dim == ents[i - 1].dim && ents[i].tag == ents[i - 1].tag) continue;
    gmshModelAddDiscreteEntity(ents[i].dim, ents[i].tag, NULL, 0, &ierr);
    if (gm_failed(ierr, msg, sizeof msg)) {
      s = pm_error_setf(err, PM_ERR_BACKEND, "gmsh: creating entity (%d, %d): %s", ents[i].dim,
                        ents[i].tag, msg);
      goto done;
    }
  }
  /* Nodes, entity by entity, with their parameters on curves and faces. */
  for (size_t i = 0; i < nn;) {
    size_t j = i;
    while (j < nn && nk[j].dim == nk[i].dim && nk[j].tag == nk[i].tag) ++j;
    int npar = !parametric || nk[i].tag == PM_MSH_UNTAGGED ? 0
               : (nk[i].dim == 1 || nk[i].dim == 2) ? nk[i].dim
                                                     : 0;
    for (size_t k = i; k < j; ++k) {
      int32_t v = nk[k].idx;
      tags[k - i] = (size_t)v + 1;
      memcpy(xyz + 3 * (k - i), m->xyz + 3 * (size_t)v, 3 * sizeof(double));
      for (int q = 0; q < npar; ++q) par[npar * (k - i) + q] = m->node_par[2 * (size_t)v + q];
    }
    gmshModelMeshAddNodes(nk[i].dim, nk[i].tag, tags, j - i, xyz, 3 * (j - i), par,
                          (size_t)npar * (j - i), &ierr);
    if (gm_failed(ierr, msg, sizeof msg)) {
      s = pm_error_setf(err, PM_ERR_BACKEND, "gmsh: adding nodes: %s", msg);
      goto done;
    }
    i = j;
  }
  /* Elements, entity by entity; element tags number segments, then triangles, then tets. */
  for (size_t i = 0; i < ne;) {
    size_t j = i;
    while (j < ne && ek[j].dim == ek[i].dim && ek[j].tag == ek[i].tag) ++j;
    int d = ek[i].dim, per = d + 1, type = d == 1 ? 1 : d == 2 ? 2 : 4;
    const int32_t *conn = d == 1 ? m->seg : d == 2 ? m->tri : m->tet;
    size_t base = d == 1 ? 0 : d == 2 ? (size_t)m->nseg : (size_t)m->nseg + (size_t)m->ntri;
    size_t *et = tags, *en = tags + (j - i);
    for (size_t k = i; k < j; ++k) {
      et[k - i] = base + (size_t)ek[k].idx + 1;
      for (int q = 0; q < per; ++q)
        en[(size_t)per * (k - i) + q] = (size_t)conn[(size_t)per * ek[k].idx + q] + 1;
    }
    gmshModelMeshAddElementsByType(ek[i].tag, type, et, j - i, en, (size_t)per * (j - i), &ierr);
    if (gm_failed(ierr, msg, sizeof msg)) {
      s = pm_error_setf(err, PM_ERR_BACKEND, "gmsh: adding elements: %s", msg);
      goto done;
    }
    i = j;
  }
done:
  free(nk);
  free(ek);
  free(ents);
  free(tags);
  free(xyz);
  free(par);
  return s;
}

/* %.17g: every double written comes back bit for bit. */
static void put_double(FILE *f, double x) { fprintf(f, "%.17g", x); }

/* Per-element quality as $ElementData, one block per measure, appended to the MSH file gmsh
 * wrote: every element by its tag (segments first, then triangles, then tets, as gmsh_build
 * numbers them) in the order of its $Elements blocks, so that gmsh (by tag) and meshio (by
 * order) both colour each element with its own value; -1 on segments, which have no such
 * measure. */
static pm_status msh_append_quality(const pm_mesh *m, const char *tmp, const char *path,
                                    pm_error *err) {
  size_t nelem = (size_t)m->nseg + (size_t)m->ntri + (size_t)m->ntet;
  if (nelem == 0) return PM_OK;
  pm_element_values q;
  pm_status s = pm_element_values_compute(m, &q, err);
  if (s) return s;
  ent_key *ek = malloc((nelem ? nelem : 1) * sizeof *ek);
  FILE *f = ek ? fopen(tmp, "a") : NULL;
  if (!ek || !f) {
    s = ek ? pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno))
           : pm_error_setf(err, PM_ERR_NOMEM, "out of memory writing a mesh");
    free(ek);
    pm_element_values_clear(&q);
    return s;
  }
  element_order(m, ek);
  const char *const *names = pm_element_value_names;
  for (int a = 0; a < PM_ELEMENT_VALUES; ++a) {
    /* string tag: the name; real tag: the time 0; integer tags: step 0, 1 component, count */
    fprintf(f, "$ElementData\n1\n\"%s\"\n1\n0\n3\n0\n1\n%zu\n", names[a], nelem);
    for (size_t k = 0; k < nelem; ++k) {
      const ent_key *e = &ek[k];
      size_t base = e->dim == 1 ? 0 : e->dim == 2 ? (size_t)m->nseg : (size_t)m->nseg + (size_t)m->ntri;
      fprintf(f, "%zu ", base + (size_t)e->idx + 1);
      if (e->dim == 1)
        fputs("-1", f);
      else
        put_double(f, (e->dim == 2 ? q.tri[a] : q.tet[a])[e->idx]);
      fputc('\n', f);
    }
    fputs("$EndElementData\n", f);
  }
  int bad = ferror(f);
  if (fclose(f) != 0) bad = 1;
  if (bad) s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
  free(ek);
  pm_element_values_clear(&q);
  return s;
}

pm_status pm_mesh_write_gmsh(const pm_mesh *m, pm_mesh_format fmt, int parametric,
                             const char *tmp, const char *path, pm_error *err) {
  pm_gmsh_lock();
  pm_gmsh_scope scope;
  char name[64];
  snprintf(name, sizeof name, "packmesh-write-%lu", scope_counter++);
  pm_status s = pm_gmsh_scope_enter(&scope, name, 1, err);
  if (s) {
    pm_gmsh_unlock();
    return s;
  }
  s = gmsh_build(m, fmt == PM_MESH_MSH, parametric, err);
  if (!s) {
    gm_option opt[] = {{"Mesh.MshFileVersion", 4.1, 0},  {"Mesh.Binary", 0, 0},
                       {"Mesh.SaveAll", 1, 0},           {"Mesh.SaveParametric", 1, 0},
                       {"Mesh.StlOneSolidPerSurface", 1, 0}};
    int nopt = (int)(sizeof opt / sizeof opt[0]);
    if (fmt != PM_MESH_MSH || !parametric) opt[3].value = 0; /* parameters are an MSH feature */
    options_set(opt, nopt);
    int ierr = 0;
    char msg[400];
    gm_mark();
    gmshWrite(tmp, &ierr);
    if (gm_failed(ierr, msg, sizeof msg))
      s = pm_error_setf(err, PM_ERR_BACKEND, "writing %s: gmsh: %s", path, msg);
    options_restore(opt, nopt);
  }
  pm_gmsh_scope_leave(&scope, 1);
  pm_gmsh_unlock();
  if (!s) {
    struct stat st;
    if (stat(tmp, &st) != 0 || st.st_size == 0)
      s = pm_error_setf(err, PM_ERR_BACKEND, "writing %s: gmsh wrote nothing", path);
  }
  if (!s && fmt == PM_MESH_MSH) s = msh_append_quality(m, tmp, path, err);
  return s;
}
