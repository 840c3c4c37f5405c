/* Healing an imported CAD model where a measurement says it needs it (geom_cad_heal.c has the
 * rule and the figures behind it). Every function acts on gmsh's current model and must be
 * called with the gmsh lock held (gmsh_session.h). Internal to the geom_cad backend.
 *
 * Counting and planning read the synchronized model; the repairs act on the OpenCASCADE shapes
 * only and leave the synchronization to the caller. geom_cad.c measures the first import, then
 * repairs a fresh import of the file and synchronizes once: gmsh 4.8.4 does not delete the
 * entity objects that a synchronization takes out of a model, so repairing the synchronized
 * model in place would keep every replaced face and curve allocated until the process ends.
 */
#ifndef PM_GEOM_CAD_HEAL_H
#define PM_GEOM_CAD_HEAL_H

#include <stddef.h>
#include <stdint.h>

/* What the measurement found in a model. */
typedef struct cad_heal_counts {
  int32_t entities[4]; /* vertices, curves, faces, volumes */
  int32_t coincident;  /* pairs of distinct curve-bounding vertices at one point */
  int32_t twin_faces;  /* faces that repeat an earlier face: the same boundary curves and the
                          same surface (a shell listing one surface twice under two tags) */
} cad_heal_counts;

/* Count the current gmsh model's entities and coincident vertex pairs. 0, or -1 when gmsh
 * failed. */
int cad_heal_count(cad_heal_counts *out);

typedef enum cad_heal_action {
  CAD_HEAL_NONE = 0,    /* nothing to repair */
  CAD_HEAL_SEW,         /* sew the faces (a model without volumes) */
  CAD_HEAL_FRAGMENT,    /* gmsh's RemoveAllDuplicates (touching solids) */
  CAD_HEAL_TWINS        /* drop faces listed twice (cad_heal_drop_twins) */
} cad_heal_action;

/* The repair a model with these counts gets. */
cad_heal_action cad_heal_choose(const cad_heal_counts *c);

/* Sew the current model's faces (HealShapes with sewFaces). 0, or -1. */
int cad_heal_sew(void);

/* A volume that lists a twin face, with the rest of its shell. */
typedef struct cad_twin_volume {
  int tag;
  int *face;
  int32_t nface;
} cad_twin_volume;

/* What dropping the twin faces takes: the twins and every volume that lists one. */
typedef struct cad_twin_plan {
  int *twin;
  int32_t ntwin;
  cad_twin_volume *volume;
  int32_t nvolume;
} cad_twin_plan;

/* Plan from the synchronized model. 0, or -1 when gmsh failed or memory ran out (the plan is
 * then empty). */
int cad_heal_plan_twins(cad_twin_plan *plan);
void cad_twin_plan_free(cad_twin_plan *plan);

/* Rebuild every planned volume from the rest of its shell and remove the twins, in a model
 * whose tags are those the plan was made on (the same file imported into a fresh model).
 * 0, or -1 when gmsh failed. */
int cad_heal_drop_twins(const cad_twin_plan *plan);

/* RemoveAllDuplicates. 0, or -1 when gmsh failed. */
int cad_heal_fragment(void);

/* One line saying what was found, what was done (`how`) and the counts before and after. */
void cad_heal_describe(const cad_heal_counts *before, const cad_heal_counts *after,
                       const char *how, char *text, size_t len);

#endif /* PM_GEOM_CAD_HEAL_H */
