/* Healing a freshly imported CAD model before its cell complex is built (geom_cad.c calls it):
 * what needs healing is measured first, and only then is OpenCASCADE asked to repair it through
 * gmsh, so that a file that needs nothing is taken exactly as it is.
 *
 * What is measured: pairs of distinct vertices of the model that lie on each other (within
 * COINCIDENT_TOL of the bounding-box diagonal) and both bound curves. A well-formed B-rep has one
 * vertex where curves meet; two vertices at one place mean faces that were never sewn (an open
 * shell exported face by face: step/sewfaces.step, step/mesh_T106_V3.step) or solids that touch
 * without sharing their faces (an assembly: occ_large/ring.brep). Meshed as they are, they give
 * two nodes at one place and two meshes of one surface, and the checker rejects the result.
 * Vertices that bound nothing (construction points, see geom.h's `stray`) are not counted.
 *
 * What is done, measured on ../shared/cad/robust (gmsh 4.8.4, OpenCASCADE 7.6.3):
 *   - a model without volumes is sewn (gmsh's HealShapes with sewFaces, OpenCASCADE's
 *     BRepBuilderAPI_Sewing): sewfaces.step 30 -> 26 vertices in 0.01 s, mesh_T106_V3.step
 *     32 -> 14 in 0.04 s. Sewing is not used on solids: it rebuilds the shells and loses the
 *     volumes (ring.brep: 2 volumes -> 0, wing_fuselage.step: 2 -> 0). Where pairs are left
 *     (faces that meet along part of an edge: mesh_T106_V3.step keeps 2), the sewn model is
 *     fragmented as below (1.4 s there: the booleans of its B-spline faces);
 *   - a model with volumes gets gmsh's RemoveAllDuplicates (a boolean fragment of every entity,
 *     what gmsh's "Coherence" does), which makes touching solids share their faces: ring.brep
 *     14 / 23 / 13 / 2 -> 8 / 13 / 7 / 2 vertices / curves / faces / volumes in 0.05 s. It is
 *     not applied blindly: on models without coincident vertices it costs up to 27 s
 *     (statreport/A319.brep) and can change a valid model (box_sides.step: 10 -> 33 volumes).
 * IGES files with coincident vertices are imported again with sewing on (geom_cad.c, heal()).
 *
 * The report (what was found and what was done) is written into the model's `heal` text, which
 * the command prints and --stats records.
 */
#include "common/geom/geom_cad_heal.h"

#include <gmshc.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Two vertices closer than this fraction of the diagonal are one point of the B-rep. OCC's
 * confusion tolerance is 1e-7 model units; exported assemblies repeat a vertex to the last bit
 * (the coincident pairs of the robust corpus are 0 to 4e-17 of the diagonal apart), while the
 * closest distinct vertices of the shared models are 4e-5 of the diagonal apart. */
#define COINCIDENT_TOL 1e-9

typedef struct vpt {
  double x[3];
} vpt;

static int cmp_vpt_x(const void *a, const void *b) {
  double p = ((const vpt *)a)->x[0], q = ((const vpt *)b)->x[0];
  return (p > q) - (p < q);
}

/* ---- twin faces ---------------------------------------------------------------------------- */

typedef struct face_sig {
  int tag;
  int32_t ncurve;
  int *curve;      /* sorted boundary curve tags (signs dropped) */
  double lo[2], hi[2], mid[3];
  char type[32];
} face_sig;

static int cmp_int(const void *a, const void *b) {
  int x = *(const int *)a, y = *(const int *)b;
  return (x > y) - (x < y);
}

/* Same boundary, same parametrization box, same point at its centre, same surface type. */
static int same_face(const face_sig *a, const face_sig *b, double tol) {
  if (a->ncurve != b->ncurve || a->ncurve == 0 || strcmp(a->type, b->type)) return 0;
  if (memcmp(a->curve, b->curve, sizeof(int) * (size_t)a->ncurve)) return 0;
  for (int k = 0; k < 2; ++k)
    if (fabs(a->lo[k] - b->lo[k]) > 1e-9 * (1 + fabs(a->lo[k])) ||
        fabs(a->hi[k] - b->hi[k]) > 1e-9 * (1 + fabs(a->hi[k])))
      return 0;
  double d = 0;
  for (int k = 0; k < 3; ++k) d += (a->mid[k] - b->mid[k]) * (a->mid[k] - b->mid[k]);
  return d <= tol * tol;
}

/* The tags of the faces that repeat an earlier one (by tag order): *twin (free()) and *n. */
static int find_twins(double tol, int **twin, int32_t *n) {
  *twin = NULL, *n = 0;
  int ierr = 0, *dt = NULL;
  size_t nd = 0;
  gmshModelGetEntities(&dt, &nd, 2, &ierr);
  if (ierr) {
    if (dt) gmshFree(dt);
    return -1;
  }
  int32_t nf = (int32_t)(nd / 2);
  face_sig *f = calloc((size_t)(nf ? nf : 1), sizeof(face_sig));
  *twin = malloc(sizeof(int) * (size_t)(nf ? nf : 1));
  if (!f || !*twin) {
    free(f), free(*twin), *twin = NULL;
    gmshFree(dt);
    return -1;
  }
  int rc = 0;
  for (int32_t i = 0; i < nf && !rc; ++i) {
    f[i].tag = dt[2 * i + 1];
    int *up = NULL, *down = NULL;
    size_t nu = 0, ndn = 0;
    gmshModelGetAdjacencies(2, f[i].tag, &up, &nu, &down, &ndn, &ierr);
    f[i].curve = malloc(sizeof(int) * (ndn + 1));
    if (ierr || !f[i].curve) rc = -1;
    for (size_t k = 0; !rc && k < ndn; ++k) f[i].curve[f[i].ncurve++] = abs(down[k]);
    if (up) gmshFree(up);
    if (down) gmshFree(down);
    if (rc) break;
    qsort(f[i].curve, (size_t)f[i].ncurve, sizeof(int), cmp_int);
    double *a = NULL, *b = NULL, *x = NULL;
    size_t na = 0, nb = 0, nx = 0;
    char *t = NULL;
    gmshModelGetType(2, f[i].tag, &t, &ierr);
    snprintf(f[i].type, sizeof f[i].type, "%s", t ? t : "");
    if (t) gmshFree(t);
    gmshModelGetParametrizationBounds(2, f[i].tag, &a, &na, &b, &nb, &ierr);
    if (!ierr && na == 2 && nb == 2) {
      double c[2] = {0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])};
      f[i].lo[0] = a[0], f[i].lo[1] = a[1], f[i].hi[0] = b[0], f[i].hi[1] = b[1];
      gmshModelGetValue(2, f[i].tag, c, 2, &x, &nx, &ierr);
      if (!ierr && nx == 3) memcpy(f[i].mid, x, sizeof f[i].mid);
      else f[i].ncurve = 0; /* not comparable */
    } else {
      f[i].ncurve = 0;
    }
    ierr = 0;
    if (a) gmshFree(a);
    if (b) gmshFree(b);
    if (x) gmshFree(x);
  }
  /* Quadratic in the faces sharing a first curve only: compare within runs of equal first
   * curves after sorting by it would be faster, but twins are rare and the check is cheap. */
  for (int32_t i = 0; i < nf && !rc; ++i)
    for (int32_t j = 0; j < i; ++j)
      if (f[i].ncurve > 0 && f[i].curve[0] == f[j].curve[0] && same_face(&f[j], &f[i], tol)) {
        (*twin)[(*n)++] = f[i].tag;
        break;
      }
  for (int32_t i = 0; i < nf; ++i) free(f[i].curve);
  free(f);
  gmshFree(dt);
  if (rc) free(*twin), *twin = NULL, *n = 0;
  return rc;
}

static double model_diagonal(void) {
  int ierr = 0;
  double box[6];
  gmshModelGetBoundingBox(-1, -1, &box[0], &box[1], &box[2], &box[3], &box[4], &box[5], &ierr);
  double diag = ierr ? 0 : sqrt(pow(box[3] - box[0], 2) + pow(box[4] - box[1], 2) +
                                pow(box[5] - box[2], 2));
  return diag > 0 && isfinite(diag) ? diag : 1;
}

int cad_heal_plan_twins(cad_twin_plan *plan) {
  memset(plan, 0, sizeof *plan);
  int *twin = NULL;
  int32_t nt = 0;
  if (find_twins(COINCIDENT_TOL * model_diagonal(), &twin, &nt)) return -1;
  plan->twin = twin;
  plan->ntwin = nt;
  int ierr = 0;
  for (int32_t k = 0; k < nt && !ierr; ++k) {
    /* Every volume listing the twin is rebuilt from its other faces. */
    int *up = NULL, *down = NULL;
    size_t nu = 0, nd = 0;
    gmshModelGetAdjacencies(2, twin[k], &up, &nu, &down, &nd, &ierr);
    for (size_t v = 0; !ierr && v < nu; ++v) {
      int in[2] = {3, up[v]}, *bd = NULL;
      size_t nb = 0;
      gmshModelGetBoundary(in, 2, &bd, &nb, 0, 0, 0, &ierr);
      cad_twin_volume *grown =
          ierr ? NULL : realloc(plan->volume, sizeof *grown * (size_t)(plan->nvolume + 1));
      int *faces = grown ? malloc(sizeof(int) * (nb / 2 + 1)) : NULL;
      if (grown) plan->volume = grown;
      if (!faces) ierr = 1;
      size_t nfc = 0;
      for (size_t q = 0; !ierr && q < nb / 2; ++q)
        if (abs(bd[2 * q + 1]) != twin[k]) faces[nfc++] = abs(bd[2 * q + 1]);
      if (bd) gmshFree(bd);
      if (!ierr)
        plan->volume[plan->nvolume++] = (cad_twin_volume){up[v], faces, (int32_t)nfc};
    }
    if (up) gmshFree(up);
    if (down) gmshFree(down);
  }
  if (ierr) cad_twin_plan_free(plan);
  return ierr ? -1 : 0;
}

int cad_heal_drop_twins(const cad_twin_plan *plan) {
  int ierr = 0;
  for (int32_t v = 0; v < plan->nvolume && !ierr; ++v) {
    const cad_twin_volume *tv = &plan->volume[v];
    int loop = gmshModelOccAddSurfaceLoop(tv->face, (size_t)tv->nface, -1, 0, &ierr);
    if (!ierr) gmshModelOccAddVolume(&loop, 1, -1, &ierr);
    int old[2] = {3, tv->tag};
    if (!ierr) gmshModelOccRemove(old, 2, 0, &ierr);
  }
  for (int32_t k = 0; k < plan->ntwin && !ierr; ++k) {
    int tw[2] = {2, plan->twin[k]};
    gmshModelOccRemove(tw, 2, 0, &ierr);
  }
  return ierr ? -1 : 0;
}

void cad_twin_plan_free(cad_twin_plan *plan) {
  for (int32_t v = 0; v < plan->nvolume; ++v) free(plan->volume[v].face);
  free(plan->volume);
  free(plan->twin);
  memset(plan, 0, sizeof *plan);
}

/* ---- counting ------------------------------------------------------------------------------- */

int cad_heal_count(cad_heal_counts *out) {
  memset(out, 0, sizeof *out);
  int ierr = 0, *dt = NULL;
  size_t n = 0;
  for (int d = 0; d < 4; ++d) {
    dt = NULL, n = 0;
    gmshModelGetEntities(&dt, &n, d, &ierr);
    if (ierr) {
      if (dt) gmshFree(dt);
      return -1;
    }
    out->entities[d] = (int32_t)(n / 2);
    if (d == 0) {
      /* The vertices that bound a curve. */
      vpt *v = malloc(sizeof(vpt) * (n / 2 + 1));
      if (!v) {
        gmshFree(dt);
        return -1;
      }
      int32_t nv = 0;
      for (size_t i = 0; i < n / 2; ++i) {
        int *up = NULL, *down = NULL;
        size_t nu = 0, nd = 0;
        gmshModelGetAdjacencies(0, dt[2 * i + 1], &up, &nu, &down, &nd, &ierr);
        if (up) gmshFree(up);
        if (down) gmshFree(down);
        if (ierr || nu == 0) continue;
        double *x = NULL;
        size_t nx = 0;
        gmshModelGetValue(0, dt[2 * i + 1], NULL, 0, &x, &nx, &ierr);
        if (!ierr && nx == 3 && isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]))
          memcpy(v[nv++].x, x, sizeof v->x);
        if (x) gmshFree(x);
      }
      const double tol = COINCIDENT_TOL * model_diagonal();
      /* Sort and sweep along x: pairs within tol in x, then in space. */
      qsort(v, (size_t)nv, sizeof(vpt), cmp_vpt_x);
      for (int32_t i = 0; i < nv; ++i)
        for (int32_t j = i + 1; j < nv && v[j].x[0] - v[i].x[0] <= tol; ++j) {
          double dx = v[j].x[0] - v[i].x[0], dy = v[j].x[1] - v[i].x[1], dz = v[j].x[2] - v[i].x[2];
          if (dx * dx + dy * dy + dz * dz <= tol * tol) out->coincident++;
        }
      free(v);
    }
    if (dt) gmshFree(dt);
  }
  int *twin = NULL;
  if (find_twins(COINCIDENT_TOL * model_diagonal(), &twin, &out->twin_faces)) return -1;
  free(twin);
  return 0;
}

cad_heal_action cad_heal_choose(const cad_heal_counts *c) {
  /* Sewing and fragmenting join faces and solids: curves alone (a wire model) are left as they
   * are, their coincident ends included. */
  if (c->entities[2] == 0) return CAD_HEAL_NONE;
  if (c->coincident == 0) return c->twin_faces > 0 ? CAD_HEAL_TWINS : CAD_HEAL_NONE;
  return c->entities[3] > 0 ? CAD_HEAL_FRAGMENT : CAD_HEAL_SEW;
}

int cad_heal_sew(void) {
  int ierr = 0, *out = NULL;
  size_t nout = 0;
  /* The tolerance is gmsh's default Geometry.Tolerance: the coincident pairs are far closer. */
  gmshModelOccHealShapes(&out, &nout, NULL, 0, 1e-8, 0, 0, 0, 1, 0, &ierr);
  if (out) gmshFree(out);
  return ierr ? -1 : 0;
}

int cad_heal_fragment(void) {
  int ierr = 0;
  gmshModelOccRemoveAllDuplicates(&ierr);
  return ierr ? -1 : 0;
}

void cad_heal_describe(const cad_heal_counts *before, const cad_heal_counts *after,
                       const char *how, char *text, size_t len) {
  const char *what = before->coincident > 0
                         ? "coincident vertex pairs (unsewn faces or touching solids)"
                         : "faces listed twice (one surface and boundary under two tags)";
  int w = snprintf(text, len,
                   "%s: %d; %s: "
                   "%d / %d / %d / %d -> %d / %d / %d / %d vertices / curves / faces / volumes",
                   what, (int)(before->coincident > 0 ? before->coincident : before->twin_faces),
                   how, (int)before->entities[0], (int)before->entities[1],
                   (int)before->entities[2], (int)before->entities[3], (int)after->entities[0],
                   (int)after->entities[1], (int)after->entities[2], (int)after->entities[3]);
  if (after->coincident > 0 && w > 0 && (size_t)w < len)
    snprintf(text + w, len - (size_t)w, ", %d pairs left", (int)after->coincident);
}
