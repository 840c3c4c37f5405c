/* Healing an imported CAD model where a measurement says it needs it (geom_cad_heal.c has the
 * rule and the figures behind it). Every function acts on gmsh's current model and must be
 * called with the gmsh lock held (gmsh_session.h). Internal to the geom_cad backend.
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

/* Sew the current model's faces (HealShapes with sewFaces) and synchronize. 0, or -1. */
int cad_heal_sew(void);

/* Take every twin face out of the volumes that list it (each such volume is rebuilt from the
 * rest of its shell) and remove it, then synchronize. 0, or -1 when gmsh failed. */
int cad_heal_drop_twins(void);

/* RemoveAllDuplicates and synchronize the current model. 0, or -1 when gmsh failed. */
int cad_heal_fragment(void);

/* One line saying what was found, what was done (`how`) and the counts before and after. */
void cad_heal_describe(const cad_heal_counts *before, const cad_heal_counts *after,
                       const char *how, char *text, size_t len);

#endif /* PM_GEOM_CAD_HEAL_H */
