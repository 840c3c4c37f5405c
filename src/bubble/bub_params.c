/* The parameters of the bubble method: one table (params.h) gives every field its default,
 * range, unit, meaning and source; --set, --help and the range checks come from it. The
 * relations between fields (cut-offs in order, a stable time step) are checked by
 * bub_params_check. */
#include "bubble/bub_private.h"

#include <complex.h>
#include <math.h>
#include <stddef.h>

static const char *const integrators[] = {"rk4", "rk2", "symplectic", NULL};
static const char *const viscosities[] = {"constant", "sawtooth", NULL};
static const char *const tet_sources[] = {"bubbles", "tetgen", NULL};
static const char *const placements[] = {"quadtree", "lattice", NULL};

#define F(field) offsetof(bub_params, field)

static const pm_param_desc desc[] = {
    /* force and dynamics */
    {"k0", PM_PARAM_DOUBLE, F(k0), 30, 0, 1e6, PM_RANGE_LO_OPEN, "force/length",
     "spring constant of the inter-bubble force at l0 (f'(l0) = -k0)",
     "003 eq. 11, 004 eq. 2.1; 000 sec. 6.4 (best near 30)", NULL},
    {"mass", PM_PARAM_DOUBLE, F(mass), 1, 0, 1e6, PM_RANGE_LO_OPEN, "", "bubble mass m",
     "003 eq. 12, 000 sec. 6.4", NULL},
    {"zeta", PM_PARAM_DOUBLE, F(zeta), 0.7, 0, 10, PM_RANGE_LO_OPEN, "",
     "damping ratio c / (2 sqrt(m k0)); start of each round under the saw-tooth", "003 eq. 14",
     NULL},
    {"dt", PM_PARAM_DOUBLE, F(dt), 0, 0, 0.2, PM_RANGE_CLOSED, "T0",
     "time step as a fraction of the natural period 2 pi sqrt(m/k0); 0 = automatic (rk4 and "
     "symplectic 0.1, rk2 0.05)",
     "our choice (bub_dynamics.c)", NULL},
    {"integrator", PM_PARAM_CHOICE, F(integrator), BUB_SYMPLECTIC, 0, 0, 0, "",
     "fourth-order Runge-Kutta, the second-order (Heun) scheme, or semi-implicit Euler with "
     "implicit damping (one force sum a step instead of four; the same rest point)",
     "003 sec. 3.4; 004 sec. 1; symplectic: our addition (bub_dynamics.c)",
     integrators},
    /* viscosity */
    {"viscosity", PM_PARAM_CHOICE, F(viscosity), BUB_VISC_SAWTOOTH, 0, 0, 0, "",
     "constant damping (classic) or the saw-tooth rise within and across rounds", "004 sec. 2.2",
     viscosities},
    {"zeta_k1", PM_PARAM_DOUBLE, F(zeta_k1), 0.05, 0, 1, PM_RANGE_CLOSED, "/step",
     "saw-tooth: rise of the damping ratio per step within a round", "004 sec. 2.2 (k1)", NULL},
    {"zeta_k2", PM_PARAM_DOUBLE, F(zeta_k2), 0.02, 0, 1, PM_RANGE_CLOSED, "/round",
     "saw-tooth: rise of the damping ratio per round", "004 sec. 2.2 (k2)", NULL},
    {"zeta_max", PM_PARAM_DOUBLE, F(zeta_max), 1.5, 0.1, 10, PM_RANGE_CLOSED, "",
     "saw-tooth: cap of the damping ratio", "our choice (stability of the step)", NULL},
    {"final_zeta", PM_PARAM_DOUBLE, F(final_zeta), 0, -1, 10, PM_RANGE_CLOSED, "",
     "damping ratio of curved faces' bubbles in the surface phase's final steps; 0 = "
     "automatic (rk4 and symplectic 0.3, rk2 the schedule: its step needs more damping), -1 = the viscosity "
     "schedule goes on (at its cap)",
     "our choice (bub_run.c; bench_bubble compare, timing)", NULL},
    {"zeta_odd", PM_PARAM_DOUBLE, F(zeta_odd), 0.5, 0, 10, PM_RANGE_LO_OPEN, "",
     "damping ratio of bubbles next to an insertion or deletion, for one round",
     "004 sec. 2.2 (c_odd = 1 at m = k0 = 1)", NULL},
    {"odd_from", PM_PARAM_DOUBLE, F(odd_from), 0.0005, 0, 1, PM_RANGE_CLOSED, "",
     "odd-bubble damping starts once a control changes the count by at most this fraction",
     "004 sec. 2.2 (0.05%)", NULL},
    /* speed */
    {"list_skin", PM_PARAM_DOUBLE, F(list_skin), 0.15, 0.02, 2, PM_RANGE_CLOSED, "",
     "neighbour lists: pairs within (1 + list_skin) 1.5 l0, rebuilt from the outer lists once two "
     "bubbles may have crossed the skin",
     "our choice (bub_neighbors.c; bench_bubble)", NULL},
    {"list_outer", PM_PARAM_DOUBLE, F(list_outer), 0.6, 0.02, 3, PM_RANGE_CLOSED, "",
     "outer neighbour lists: pairs within (1 + list_outer) 1.5 l0, from the grid once two bubbles "
     "may have crossed that skin (>= list_skin)",
     "our choice (bub_neighbors.c; bench_bubble)", NULL},
    {"list_partial", PM_PARAM_DOUBLE, F(list_partial), 0.125, 0, 1, PM_RANGE_CLOSED, "",
     "when the skin test fails, rebuild only the lists of the bubbles that used up half their "
     "skin (and of their neighbours) while they are at most this fraction of the moving bubbles; "
     "0 = every list every time",
     "our choice (bub_neighbors.c; forces as exact either way)", NULL},
    {"frame_tol", PM_PARAM_DOUBLE, F(frame_tol), 0.05, 0, 0.5, PM_RANGE_CLOSED, "d",
     "a bubble within frame_tol d of its last exact evaluation uses its cell's second-order "
     "Taylor model there (0 = exact evaluation at every RK stage)",
     "our choice (bub_dynamics.c)", NULL},
    /* placement */
    {"place", PM_PARAM_CHOICE, F(place), BUB_PLACE_LATTICE, 0, 0, 0, "",
     "face bubbles from the rhombic quadtree (the papers) or a hexagonal lattice grown from the "
     "border at the stable distance",
     "003 sec. 3.2, 000 sec. 4.1.1; lattice: our addition (bub_lattice.c)", placements},
    {"hold_rings", PM_PARAM_INT, F(hold_rings), 4, 0, 100, PM_RANGE_CLOSED, "rings",
     "place=lattice, planes: a face bubble whose lattice sites within this many rings are all "
     "placed, in its grain, at its own size, is held where it was placed: only the bubbles near "
     "borders, grain boundaries and size changes relax (0: every bubble relaxes)",
     "our addition (bub_lattice.c; bench_bubble compare); differs from the papers (0)", NULL},
    {"lattice_fit", PM_PARAM_BOOL, F(lattice_fit), 1, 0, 1, 0, "",
     "place=lattice, planes: a grain steps at its seed chord's length over that chord's stable "
     "distance (within 1.2%), so its rows continue the border's spacing (0: at the stable distance)",
     "our addition (bub_lattice.c; bench_bubble compare)", NULL},
    {"lattice_apex", PM_PARAM_BOOL, F(lattice_apex), 1, 0, 1, 0, "",
     "place=lattice, curved faces: a site next to two placed bubbles goes to the apex of the "
     "triangle on them at the stable distance (0: a step from one along its row)",
     "our addition (bub_lattice.c; bench_bubble timing)", NULL},
    {"w1", PM_PARAM_DOUBLE, F(w1), 1, 0, 4, PM_RANGE_LO_OPEN, "",
     "curve subdivision weight: split while w1 |P1P2| > r1 + r2", "004 sec. 2.3", NULL},
    {"w2", PM_PARAM_DOUBLE, F(w2), 0.5, 0, 1, PM_RANGE_LO_OPEN, "",
     "face quadtree weight: split while w2 |PiPj| > ri + rj (004: 0.5..0.8)", "004 sec. 2.3",
     NULL},
    /* population control */
    {"population", PM_PARAM_BOOL, F(population), 1, 0, 1, 0, "", "adaptive population control",
     "003 sec. 3.5", NULL},
    {"face_open", PM_PARAM_DOUBLE, F(face_open), 5.6, 0, 12, PM_RANGE_LO_OPEN, "",
     "a face bubble with overlap ratio below this is open (000: 5)",
     "000 sec. 4.1.2; 5.6: our choice with place=lattice (bench_bubble compare)", NULL},
    {"face_excess", PM_PARAM_DOUBLE, F(face_excess), 7, 0, 30, PM_RANGE_LO_OPEN, "",
     "a face bubble with overlap ratio above this is excess (000: 8)",
     "000 sec. 4.1.2; 7: our choice with place=lattice (bench_bubble compare)", NULL},
    {"curved_open", PM_PARAM_DOUBLE, F(curved_open), 5, 0, 6, PM_RANGE_CLOSED, "",
     "a bubble of a curved face (not a plane) with overlap ratio below this is open (0: "
     "face_open)",
     "000 sec. 4.1.2; curved faces apart: our choice (bub_population.c; bench_bubble timing)", NULL},
    {"curved_excess", PM_PARAM_DOUBLE, F(curved_excess), 8, 0, 30, PM_RANGE_CLOSED, "",
     "a bubble of a curved face with overlap ratio above this is excess (0: face_excess)",
     "000 sec. 4.1.2; curved faces apart: our choice (bub_population.c; bench_bubble timing)", NULL},
    {"curve_open", PM_PARAM_DOUBLE, F(curve_open), 5.0 / 3.0, 0, 4, PM_RANGE_LO_OPEN, "",
     "a curve bubble with overlap ratio below this is open", "our choice: face cut-off x 2/6",
     NULL},
    {"curve_excess", PM_PARAM_DOUBLE, F(curve_excess), 8.0 / 3.0, 0, 10, PM_RANGE_LO_OPEN, "",
     "a curve bubble with overlap ratio above this is excess", "our choice: face cut-off x 2/6",
     NULL},
    {"volume_open", PM_PARAM_DOUBLE, F(volume_open), 10, 0, 40, PM_RANGE_LO_OPEN, "",
     "a volume bubble with overlap ratio below this is open (standard value 12)",
     "our choice: 2 of 12 neighbours missing, as 1 of 6 (bub_population.c)", NULL},
    {"volume_excess", PM_PARAM_DOUBLE, F(volume_excess), 14, 0, 60, PM_RANGE_LO_OPEN, "",
     "a volume bubble with overlap ratio above this is excess (below every interstitial site)",
     "our choice: a bubble pushed into the FCC packing reads 13.9-14.7 (bub_population.c)",
     NULL},
    {"insert_excess", PM_PARAM_DOUBLE, F(insert_excess), 8, 0, 30, PM_RANGE_CLOSED, "",
     "a face insertion place with an overlap ratio above max(face_excess, this) is not used",
     "our choice: 000 sec. 4.1.2's excess cut-off 8 (bub_population.c)", NULL},
    {"insert_k", PM_PARAM_DOUBLE, F(insert_k), 1.8, 0.5, 4, PM_RANGE_CLOSED, "r",
     "a new face bubble is placed k bubble radii from the open one", "000 sec. 4.2.4", NULL},
    {"control_steps", PM_PARAM_INT, F(control_steps), 20, 1, 100000, PM_RANGE_CLOSED, "steps",
     "relaxation steps between two population controls (a round)", "000 sec. 4.2.6", NULL},
    {"calm", PM_PARAM_DOUBLE, F(calm), 0.02, 0, 1, PM_RANGE_LO_OPEN, "d",
     "control only when no bubble moved more than this x its diameter in the last step",
     "003 sec. 3.5", NULL},
    {"outside_layer", PM_PARAM_BOOL, F(outside_layer), 1, 0, 1, 0, "",
     "overlap-only bubbles outside the face borders", "000 sec. 4.2.1", NULL},
    /* stopping */
    {"adaptive_stop", PM_PARAM_BOOL, F(adaptive_stop), 1, 0, 1, 0, "",
     "stop when the count changes little in consecutive rounds", "004 sec. 2.4", NULL},
    {"stop_change", PM_PARAM_DOUBLE, F(stop_change), 0.005, 0, 1, PM_RANGE_CLOSED, "",
     "adaptive stop: largest relative count change of a settled round", "004 sec. 2.4 (0.5%)",
     NULL},
    {"stop_rounds", PM_PARAM_INT, F(stop_rounds), 2, 1, 1000, PM_RANGE_CLOSED, "rounds",
     "adaptive stop: settled rounds in a row", "004 sec. 2.4 (twice)", NULL},
    {"disp_tol", PM_PARAM_DOUBLE, F(disp_tol), 1e-3, 0, 1, PM_RANGE_CLOSED, "d",
     "stop when no bubble moves more than this x its diameter in a step (population settled)",
     "003 sec. 3.4", NULL},
    {"disp_quantile", PM_PARAM_DOUBLE, F(disp_quantile), 0.99, 0, 1, PM_RANGE_LO_OPEN, "",
     "the calm and displacement tests read this quantile of the bubbles' displacement / d "
     "(1 = the largest, the papers)",
     "our choice (bub_run.c: a step count that does not grow with n)", NULL},
    {"final_steps", PM_PARAM_INT, F(final_steps), 50, 0, 1000000, PM_RANGE_CLOSED, "steps",
     "relaxation steps after the population has settled, at most", "our choice", NULL},
    {"max_steps", PM_PARAM_INT, F(max_steps), 3000, 0, 100000000, PM_RANGE_CLOSED, "steps",
     "cap on the number of steps", "003 sec. 3.4", NULL},
    {"max_bubbles", PM_PARAM_DOUBLE, F(max_bubbles), 1e7, 1, 2e9, PM_RANGE_CLOSED, "",
     "cap on the number of bubbles", "our choice", NULL},
    /* default size */
    {"size_div", PM_PARAM_DOUBLE, F(size_div), 30, 1, 1e6, PM_RANGE_CLOSED, "",
     "default size: bounding-box diagonal / size_div, reduced at small features",
     "our choice (bub_size.c)", NULL},
    {"size_grade", PM_PARAM_DOUBLE, F(size_grade), 0.3, 0.01, 2, PM_RANGE_CLOSED, "",
     "default size: growth per unit distance away from a small feature", "our choice", NULL},
    /* volumes */
    {"tets", PM_PARAM_CHOICE, F(tets), BUB_TETS_BUBBLES, 0, 0, 0, "",
     "--volume: tets from packed volume bubbles (no Steiner point) or TetGen's refinement",
     "003 sec. 3.2-3.5; 001 sec. 4.4", tet_sources},
    {"sliver_angle", PM_PARAM_DOUBLE, F(sliver_angle), 10, 0, 30, PM_RANGE_CLOSED, "deg",
     "tets=bubbles: drop a volume bubble of each tet with a dihedral angle below this (a node "
     "at the centroid of one with surface corners only), tetrahedralize again (0 = off)",
     "our addition (bub_run.c)", NULL},
    /* connection */
    {"metric_flips", PM_PARAM_BOOL, F(metric_flips), 1, 0, 1, 0, "",
     "connection: flip each face's parameter-space triangulation towards the Delaunay criterion "
     "of the surface's local metric (0: 001 eq. 16's one affine map per face alone)",
     "our addition (connect.c)", NULL},
    {"drop_crossed", PM_PARAM_BOOL, F(drop_crossed), 1, 0, 1, 0, "",
     "connection: drop the face nodes that lie beyond a boundary segment in 3D but inside it in "
     "(u, v) -- a pcurve off its curve, a chord sagging inside a coarse arc (0: keep every node, "
     "as the papers do)",
     "our addition (connect.c, step 1b)", NULL},
    {"smooth", PM_PARAM_INT, F(smooth), 4, 0, 100, PM_RANGE_CLOSED, "sweeps",
     "connection: sweeps of smart Laplacian smoothing of each face's interior nodes after the "
     "flips, each move kept only when its ring's R/l_min improves (0: the nodes as placed)",
     "our addition (connect/face_smooth.h); differs from the papers (0)", NULL},
    {"needle_moves", PM_PARAM_BOOL, F(needle_moves), 1, 0, 1, PM_RANGE_CLOSED, "",
     "connection: the smoothing first tries to move a face node with an angle below 10 degrees in "
     "its ring towards the edge opposite that angle, then the Laplacian move (a face node far "
     "above curve nodes spaced finer than the face's; 0: Laplacian moves only)",
     "our addition (connect/face_smooth.h); differs from the papers (0)", NULL},
    /* output */
    {"frame_every", PM_PARAM_INT, F(frame_every), 10, 1, 1000000, PM_RANGE_CLOSED, "steps",
     "--frames: one snapshot every this many steps", "-", NULL},
};

const pm_param_table bub_params_table = {"bubble", desc, (int)(sizeof desc / sizeof desc[0])};

void bub_params_init(bub_params *p) { pm_params_defaults(&bub_params_table, p); }

/* Stability of the linearized dynamics under the integrator: every mode of a bubble is
 * m s^2 + c s + k = 0 with k between 0 and the largest stiffness of a lattice mode. A hexagonal
 * lattice of pair stiffness k has modes up to 6 k (at the M point of its Brillouin zone), a
 * face-centred cubic one (volume bubbles) up to 8 k (at its X point), and the cubic's steepest
 * slope is 1.5 k0 (at lambda = 19/30), so k <= 12 k0. The step is stable when
 * the amplification |R(h s)| <= 1 for all of them, R the scheme's stability polynomial. Checked
 * by sampling k. The symplectic scheme (semi-implicit Euler, damping implicit) maps a mode's
 * (x, v) by a 2 x 2 matrix with characteristic polynomial (1 + a) l^2 - (2 + a - b) l + 1, a = h c
 * / m, b = h^2 k / m; both roots lie in the unit disk (Jury's test) iff 0 <= b <= 4 + 2 a, so
 * the check is that one inequality at the largest k. */
static double amplification(int integrator, double complex z) {
  double complex r = 1 + z + z * z / 2;
  if (integrator == BUB_RK4) r += z * z * z / 6 + z * z * z * z / 24;
  return cabs(r);
}

static int step_stable(const bub_params *p, double zeta) {
  double h = bub_time_step(p), m = p->mass, c = 2 * zeta * sqrt(m * p->k0);
  if (p->integrator == BUB_SYMPLECTIC) return h * h * 12 * p->k0 / m <= 4 + 2 * h * c / m;
  for (int k = 0; k <= 400; ++k) {
    double kk = 12 * p->k0 * k / 400.0;
    double complex disc = csqrt((double complex)(c * c - 4 * m * kk));
    double complex s1 = (-c + disc) / (2 * m), s2 = (-c - disc) / (2 * m);
    if (amplification(p->integrator, h * s1) > 1 + 1e-12) return 0;
    if (amplification(p->integrator, h * s2) > 1 + 1e-12) return 0;
  }
  return 1;
}

pm_status bub_params_check(const bub_params *p, pm_error *err) {
  pm_status s = pm_params_check(&bub_params_table, p, err);
  if (s) return s;
  if (!(p->face_open < 6 && p->face_excess > 6 && p->face_open < p->face_excess))
    return pm_error_setf(err, PM_ERR_ARG,
                         "bubble parameters face_open=%g and face_excess=%g must satisfy "
                         "face_open < 6 < face_excess",
                         p->face_open, p->face_excess);
  {
    const double co = p->curved_open > 0 ? p->curved_open : p->face_open;
    const double ce = p->curved_excess > 0 ? p->curved_excess : p->face_excess;
    if (!(co < 6 && ce > 6))
      return pm_error_setf(err, PM_ERR_ARG,
                           "bubble parameters curved_open=%g and curved_excess=%g must satisfy "
                           "curved_open < 6 < curved_excess (0: the face cut-off)",
                           p->curved_open, p->curved_excess);
  }
  if (!(p->curve_open < 2 && p->curve_excess > 2))
    return pm_error_setf(err, PM_ERR_ARG,
                         "bubble parameters curve_open=%g and curve_excess=%g must satisfy "
                         "curve_open < 2 < curve_excess",
                         p->curve_open, p->curve_excess);
  if (!(p->list_outer >= p->list_skin))
    return pm_error_setf(err, PM_ERR_ARG,
                         "bubble parameters list_skin=%g and list_outer=%g must satisfy "
                         "list_skin <= list_outer",
                         p->list_skin, p->list_outer);
  if (!(p->volume_open < 12 && p->volume_excess > 12))
    return pm_error_setf(err, PM_ERR_ARG,
                         "bubble parameters volume_open=%g and volume_excess=%g must satisfy "
                         "volume_open < 12 < volume_excess",
                         p->volume_open, p->volume_excess);
  /* Every damping ratio the run can use must give a stable step. */
  double zetas[5] = {p->zeta, p->zeta_odd, p->viscosity == BUB_VISC_SAWTOOTH ? p->zeta_max : p->zeta,
                     p->viscosity == BUB_VISC_SAWTOOTH ? fmax(p->zeta, p->zeta_max) : p->zeta,
                     bub_final_zeta(p) > 0 ? bub_final_zeta(p) : p->zeta};
  const char *names[5] = {"zeta", "zeta_odd", "zeta_max", "zeta_max", "final_zeta"};
  for (int k = 0; k < 5; ++k)
    if (!step_stable(p, zetas[k])) {
      /* Find the largest stable step for the message. */
      bub_params q = *p;
      double lo = 0, hi = 0.2;
      for (int it = 0; it < 40; ++it) {
        q.dt = 0.5 * (lo + hi);
        if (step_stable(&q, zetas[k]))
          lo = q.dt;
        else
          hi = q.dt;
      }
      return pm_error_setf(err, PM_ERR_ARG,
                           "bubble time step dt=%g (x T0) is unstable for %s=%g with the %s "
                           "integrator (stable up to dt=%.3f)",
                           bub_time_step(p) / (2 * M_PI * sqrt(p->mass / p->k0)), names[k],
                           zetas[k], integrators[p->integrator], lo);
    }
  return PM_OK;
}
