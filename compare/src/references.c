/* The papers packmesh implements, cited as papers/NNN (compare.h: pm_cmp_reference_count, _at):
 * `packmesh references` prints them; a comparison report lists the ones it cites.
 *
 * The citations are taken from the papers' own first pages; where a first page does not print
 * the venue (000 gives no institution or year), the citation says only what the document says.
 */
#include "compare/src/compare.h"

static const pm_cmp_reference refs[] = {
    {"000",
     "Saurabh Saini. Implementation and Analysis of a Bubble Packing Method for Surface Mesh "
     "Generation. Thesis (thesis director: Suneeta Ramaswami).",
     "the bubble method's details the 1995 paper leaves out: rhombic quadtree, cut-offs, "
     "population control order, stopping criteria, the k0 sweep"},
    {"001",
     "Jonathan R. Bronson, Joshua A. Levine, Ross T. Whitaker. Particle Systems for Adaptive, "
     "Isotropic Meshing of CAD Models. Engineering with Computers 30(3), 331-343, 2014; first in "
     "Proceedings of the 19th International Meshing Roundtable, Springer, 2010, 279-296.",
     "the psys method: energy, split and delete rules, parameter-space movement, the inferred "
     "sizing field, phases, the aspect-ratio box plots (Fig. 11)"},
    {"003",
     "Kenji Shimada, David C. Gossard. Bubble Mesh: Automated Triangular Meshing of Non-Manifold "
     "Geometry by Sphere Packing. Proceedings of the Third ACM Symposium on Solid Modeling and "
     "Applications (Solid Modeling '95), Salt Lake City, Utah, May 1995, 409-419. ACM, ISBN "
     "0-89791-672-7.",
     "the bubble method: cubic force, RK4 dynamics, confinement to curves and faces, overlap "
     "ratio and population control, the irregularities eps_t and eps_g"},
    {"004",
     "Nan Qi, Yufeng Nie, Weiwei Zhang. Acceleration Strategies Based on an Improved Bubble "
     "Packing Method. Communications in Computational Physics 16(1), 115-135, 2014.",
     "bubble's normalized force, variable viscosity, insertion weights, self-adaptive "
     "termination, the radius ratio and the four planar test domains qi1..qi4"},
};

int pm_cmp_reference_count(void) { return (int)(sizeof refs / sizeof refs[0]); }

const pm_cmp_reference *pm_cmp_reference_at(int i) {
  return i >= 0 && i < pm_cmp_reference_count() ? &refs[i] : NULL;
}
