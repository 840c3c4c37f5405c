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
#include "common/geom_cad_heal.h"

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
      double box[6];
      gmshModelGetBoundingBox(-1, -1, &box[0], &box[1], &box[2], &box[3], &box[4], &box[5], &ierr);
      double diag = ierr ? 0 : sqrt(pow(box[3] - box[0], 2) + pow(box[4] - box[1], 2) +
                                    pow(box[5] - box[2], 2));
      const double tol = COINCIDENT_TOL * (diag > 0 && isfinite(diag) ? diag : 1);
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
  return 0;
}

cad_heal_action cad_heal_choose(const cad_heal_counts *c) {
  if (c->coincident == 0) return CAD_HEAL_NONE;
  return c->entities[3] > 0 ? CAD_HEAL_FRAGMENT : CAD_HEAL_SEW;
}

int cad_heal_sew(void) {
  int ierr = 0, *out = NULL;
  size_t nout = 0;
  /* The tolerance is gmsh's default Geometry.Tolerance: the coincident pairs are far closer. */
  gmshModelOccHealShapes(&out, &nout, NULL, 0, 1e-8, 0, 0, 0, 1, 0, &ierr);
  if (out) gmshFree(out);
  if (!ierr) gmshModelOccSynchronize(&ierr);
  return ierr ? -1 : 0;
}

int cad_heal_fragment(void) {
  int ierr = 0;
  gmshModelOccRemoveAllDuplicates(&ierr);
  if (!ierr) gmshModelOccSynchronize(&ierr);
  return ierr ? -1 : 0;
}

void cad_heal_describe(const cad_heal_counts *before, const cad_heal_counts *after,
                       const char *how, char *text, size_t len) {
  int w = snprintf(text, len,
                   "%d pairs of coincident vertices (unsewn faces or touching solids); %s: "
                   "%d / %d / %d / %d -> %d / %d / %d / %d vertices / curves / faces / volumes",
                   (int)before->coincident, how, (int)before->entities[0], (int)before->entities[1],
                   (int)before->entities[2], (int)before->entities[3], (int)after->entities[0],
                   (int)after->entities[1], (int)after->entities[2], (int)after->entities[3]);
  if (after->coincident > 0 && w > 0 && (size_t)w < len)
    snprintf(text + w, len - (size_t)w, ", %d pairs left", (int)after->coincident);
}
