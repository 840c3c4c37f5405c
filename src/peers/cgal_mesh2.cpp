// CGAL Mesh_2 behind a plain C header (see cgal_mesh2.h). C++ only here; every exception is
// caught in peer_mesh2_run and turned into a pm_error.
//
// The pieces:
//   - Field_criteria, a model of CGAL's MeshingCriteria_2 concept (typedefs Face_handle, Quality,
//     Is_bad and is_bad_object()) built like CGAL's Delaunay_mesh_size_criteria_2: Quality is the
//     pair (squared sine of the smallest angle, (longest edge / bound)^2), and a face is
//     IMPERATIVELY_BAD when the second exceeds 1, BAD when the first is below B. The difference is
//     the bound: size_factor x d(centroid) from the caller's field instead of one constant.
//   - Hole seeds by nesting parity: after the constraints are in, a flood from the infinite face
//     (crossing a constrained edge raises the level) finds the bounded regions of even level, the
//     holes; one centroid per such region is a seed with mark = false (outside), as
//     Delaunay_mesher_2::set_seeds takes them. The same seeds go to the optimizers, which re-mark
//     the domain after every iteration from them.
//   - Refinement one point at a time (step_by_step_refine_mesh) so the vertex cap is checked
//     before every insertion.
//   - Smoothing: CGAL's Lloyd_move_2 (the move lloyd_optimize_mesh_2 makes) and Odt_move_2, an
//     optimal Delaunay triangulation move written in the same interface, driven by smooth(), the
//     iteration of CGAL's Mesh_global_optimizer_2 in a deterministic vertex order; the density
//     of both moves is d^-4 from the caller's field (CGAL's optimizer estimates the size from the
//     initial mesh's edge lengths instead).
#include "peers/cgal_mesh2.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_criteria_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_2/Face_badness.h>
#include <CGAL/Constrained_voronoi_diagram_2.h>
#include <CGAL/Mesh_2/Lloyd_move_2.h>
#include <CGAL/Triangulation_data_structure_2.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <algorithm>
#include <map>
#include <new>
#include <queue>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Delaunay_mesh_vertex_base_2<K>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds>;
using Point = CDT::Point;
using Vertex_handle = CDT::Vertex_handle;
using Face_handle = CDT::Face_handle;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The caller's field with the size factor applied.
struct Field {
  peer_mesh2_size_fn fn;
  void *user;
  double factor;
  // The bound on the longest edge at p, or 0 when the field is unusable there.
  double bound(double x, double y) const {
    const double xy[2] = {x, y};
    double d = fn(xy, user);
    return (d > 0 && std::isfinite(d)) ? factor * d : 0.0;
  }
};

// The field as the optimizers' sizing field (density d^-4): the interface of CGAL's
// Mesh_2::Sizing_field_2, operator()(point) -> size.
struct Field_sizing {
  Field field;
  double operator()(const Point &p) const {
    double b = field.bound(CGAL::to_double(p.x()), CGAL::to_double(p.y()));
    return b > 0 ? b / field.factor : 1.0;
  }
};

class Field_criteria : public CGAL::Delaunay_mesh_criteria_2<CDT> {
 public:
  using Base = CGAL::Delaunay_mesh_criteria_2<CDT>;
  using Face_handle = CDT::Face_handle;
  using Geom_traits = CDT::Geom_traits;

  // first: squared sine of the smallest angle; second: (longest edge / bound)^2.
  struct Quality : public std::pair<double, double> {
    Quality() : std::pair<double, double>(0, 0) {}
    Quality(double sine, double size) : std::pair<double, double>(sine, size) {}
    double sine() const { return first; }
    double size() const { return second; }
    // q1 < q2: q1 is refined first. Oversized faces first, the largest first; then the worst
    // shaped (the order of Delaunay_mesh_size_criteria_2::Quality).
    bool operator<(const Quality &q) const {
      if (size() > 1) return q.size() > 1 ? size() > q.size() : true;
      if (q.size() > 1) return false;
      return sine() < q.sine();
    }
  };

  class Is_bad : public Base::Is_bad {
   public:
    Is_bad(double B, const Geom_traits &traits, const Field &field)
        : Base::Is_bad(B, traits), field_(field) {}

    CGAL::Mesh_2::Face_badness operator()(const Quality q) const {
      if (q.size() > 1) return CGAL::Mesh_2::IMPERATIVELY_BAD;
      return q.sine() < this->B ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }

    CGAL::Mesh_2::Face_badness operator()(const Face_handle &fh, Quality &q) const {
      const Point &pa = fh->vertex(0)->point(), &pb = fh->vertex(1)->point(),
                  &pc = fh->vertex(2)->point();
      double a = CGAL::to_double(CGAL::squared_distance(pb, pc));
      double b = CGAL::to_double(CGAL::squared_distance(pc, pa));
      double c = CGAL::to_double(CGAL::squared_distance(pa, pb));
      double mx = std::max(a, std::max(b, c));
      double second = a + b + c - mx - std::min(a, std::min(b, c));
      double bound = field_.bound((pa.x() + pb.x() + pc.x()) / 3, (pa.y() + pb.y() + pc.y()) / 3);
      q.second = bound > 0 ? mx / (bound * bound) : 0.0;
      if (q.size() > 1) {
        q.first = 1; // the sine is not needed: the face is split anyway
        return CGAL::Mesh_2::IMPERATIVELY_BAD;
      }
      // (2 area)^2 / (l_max^2 l_second^2) is the squared sine of the angle between the two
      // longest edges, i.e. of the smallest angle (the one opposite the shortest edge).
      double area2 = 2 * CGAL::to_double(CGAL::area(pa, pb, pc));
      q.first = (mx > 0 && second > 0) ? area2 * area2 / (mx * second) : 0.0;
      return q.sine() < this->B ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
    }

   private:
    Field field_;
  };

  Field_criteria(double B, const Field &field) : Base(B), field_(field) {}
  Is_bad is_bad_object() const { return Is_bad(this->bound(), this->traits, field_); }

 private:
  Field field_;
};

// Optimal Delaunay triangulation smoothing move (see cgal_mesh2.h), in the interface of CGAL's
// Lloyd_move_2: operator()(vertex, triangulation, sizing field) -> displacement.
template <typename Tr, typename SizingField>
class Odt_move_2 {
 public:
  using Sizing_field = SizingField;
  using Vector_2 = typename Tr::Geom_traits::Vector_2;
  using FT = typename Tr::Geom_traits::FT;

  Vector_2 operator()(typename Tr::Vertex_handle v, const Tr &cdt,
                      const Sizing_field &sizing) const {
    if (cdt.are_there_incident_constraints(v)) return CGAL::NULL_VECTOR;
    const Point p = v->point();
    Vector_2 move = CGAL::NULL_VECTOR;
    FT sum = 0;
    typename Tr::Face_circulator fc = cdt.incident_faces(v), end = fc;
    if (fc == nullptr) return CGAL::NULL_VECTOR;
    do {
      if (cdt.is_infinite(fc) || !fc->is_in_domain()) return CGAL::NULL_VECTOR;
      const Point &a = fc->vertex(0)->point(), &b = fc->vertex(1)->point(),
                  &c = fc->vertex(2)->point();
      FT area = CGAL::abs(CGAL::area(a, b, c));
      Point g = CGAL::centroid(a, b, c);
      FT s = sizing(g);
      if (!(s > 0) || !(area > 0)) return CGAL::NULL_VECTOR;
      // Density s^-(d+2) with d = 2: the weight CGAL's Lloyd_move_2 gives its cells.
      FT mass = area / (s * s * s * s);
      move = move + mass * Vector_2(p, CGAL::circumcenter(a, b, c));
      sum += mass;
    } while (++fc != end);
    if (!(sum > 0)) return CGAL::NULL_VECTOR;
    move = move / sum;
    // Circumcentres of obtuse triangles lie outside them: keep the vertex inside its star
    // (every triangle (new p, a, b) over its link edges counter-clockwise), halving the move.
    for (int halve = 0; halve < 12; ++halve, move = move / 2) {
      Point q = p + move;
      bool ok = true;
      fc = end;
      do {
        int i = fc->index(v);
        const Point &a = fc->vertex(CDT::ccw(i))->point(), &b = fc->vertex(CDT::cw(i))->point();
        if (CGAL::orientation(q, a, b) != CGAL::LEFT_TURN) ok = false;
      } while (ok && ++fc != end);
      if (ok) return move;
    }
    return CGAL::NULL_VECTOR;
  }
};

// Seeds in the bounded regions of even nesting level (the holes): regions are flooded level by
// level from the infinite face, a face across a constraint from a region of level L starting a
// region of level L + 1; one seed (a face's centroid) per region of even level > 0.
std::vector<Point> hole_seeds(const CDT &cdt) {
  std::map<Face_handle, int> level;
  std::vector<Point> seeds;
  std::vector<Face_handle> now(1, cdt.infinite_face()), next;
  for (int lev = 0; !now.empty(); ++lev) {
    for (Face_handle start : now) {
      if (level.count(start)) continue; // in a region already
      level[start] = lev;
      if (lev > 0 && lev % 2 == 0)
        seeds.push_back(CGAL::centroid(start->vertex(0)->point(), start->vertex(1)->point(),
                                       start->vertex(2)->point()));
      std::queue<Face_handle> q;
      q.push(start);
      while (!q.empty()) {
        Face_handle f = q.front();
        q.pop();
        for (int i = 0; i < 3; ++i) {
          Face_handle n = f->neighbor(i);
          if (level.count(n)) continue;
          if (f->is_constrained(i)) {
            next.push_back(n);
          } else {
            level[n] = lev;
            q.push(n);
          }
        }
      }
    }
    now.swap(next);
    next.clear();
  }
  return seeds;
}

// The smoothing driver: the iteration of CGAL's Mesh_global_optimizer_2 (Jacobi moves of the
// unconstrained vertices from a move function, a vertex frozen when its move is below 0.001 of
// the smallest circumradius around it, convergence when the mean of the largest 1% of moves is
// below 0.001 of that size, each move applied by removal and re-insertion, the domain re-marked
// from the seeds), with the vertices visited in the triangulation's own order. CGAL's optimizer
// keeps its vertices in a std::set ordered by address, so its result changes from run to run; this
// order depends on the operations only. Returns why it stopped.
template <typename Move>
const char *smooth(CDT &cdt, const std::vector<Point> &seeds, const Field_sizing &sizing,
                   int iterations, int32_t *done) {
  const double freeze = 0.001, convergence = 0.001;
  Move move;
  for (int it = 0; it < iterations; *done = ++it) {
    // Lloyd's constrained Voronoi cells need the faces' blindness (which constraint hides
    // their circumcentre), as CGAL's optimizer updates it before every iteration.
    CGAL::Constrained_voronoi_diagram_2<CDT> cvd(cdt);
    cvd.tag_faces_blind();
    std::vector<std::pair<Vertex_handle, Point>> moves;
    std::vector<double> ratio;
    size_t moving = 0;
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
      Vertex_handle vh = v;
      if (cdt.are_there_incident_constraints(vh)) continue;
      ++moving;
      K::Vector_2 m = move(vh, cdt, sizing);
      if (m == CGAL::NULL_VECTOR) continue;
      double local = std::numeric_limits<double>::max();
      auto fc = cdt.incident_faces(vh), fe = fc;
      do {
        if (!cdt.is_infinite(fc)) {
          Point cc = CGAL::circumcenter(fc->vertex(0)->point(), fc->vertex(1)->point(),
                                        fc->vertex(2)->point());
          local = std::min(local, CGAL::to_double(CGAL::squared_distance(cc, fc->vertex(0)->point())));
        }
      } while (++fc != fe);
      if (!(local > 0)) continue;
      double r = std::sqrt(CGAL::to_double(m * m) / local);
      if (r < freeze) continue;
      moves.push_back(std::make_pair(vh, vh->point() + m));
      ratio.push_back(r);
    }
    if (moves.empty()) return "all vertices frozen";
    size_t k = std::max<size_t>(1, moving / 100);
    k = std::min(k, ratio.size());
    std::partial_sort(ratio.begin(), ratio.begin() + static_cast<long>(k), ratio.end(),
                      std::greater<double>());
    double big = 0;
    for (size_t i = 0; i < k; ++i) big += ratio[i];
    if (big / static_cast<double>(k) < convergence) return "converged";
    for (const auto &mv : moves) {
      cdt.remove(mv.first);
      cdt.insert(mv.second);
    }
    CGAL::Delaunay_mesher_2<CDT, Field_criteria>::mark_facets(cdt, seeds.begin(), seeds.end(), false);
  }
  return "max iterations";
}

template <typename T>
T *copy_out(const std::vector<T> &v) {
  T *p = static_cast<T *>(std::malloc(sizeof(T) * (v.size() ? v.size() : 1)));
  if (!p) throw std::bad_alloc();
  if (!v.empty()) std::memcpy(p, v.data(), sizeof(T) * v.size());
  return p;
}

struct Limit_reached {};

void run(const peer_mesh2_input *in, peer_mesh2_result *out) {
  CDT cdt;
  std::map<Vertex_handle, int32_t> index;
  std::vector<Vertex_handle> handles(static_cast<size_t>(in->npts));
  for (int32_t i = 0; i < in->npts; ++i) {
    handles[static_cast<size_t>(i)] = cdt.insert(Point(in->xy[2 * i], in->xy[2 * i + 1]));
    index[handles[static_cast<size_t>(i)]] = i;
  }
  std::map<std::pair<int32_t, int32_t>, int32_t> cons_of;
  for (int32_t k = 0; k < in->ncons; ++k) {
    int32_t a = in->cons[2 * k], b = in->cons[2 * k + 1];
    cdt.insert_constraint(handles[static_cast<size_t>(a)], handles[static_cast<size_t>(b)]);
    cons_of[std::make_pair(std::min(a, b), std::max(a, b))] = k;
  }
  std::vector<Point> seeds = hole_seeds(cdt);
  out->nseeds = static_cast<int32_t>(seeds.size());

  auto t0 = std::chrono::steady_clock::now();
  Field field{in->size, in->user, in->size_factor};
  Field_criteria criteria(in->shape_bound, field);
  CGAL::Delaunay_mesher_2<CDT, Field_criteria> mesher(cdt, criteria);
  mesher.set_seeds(seeds.begin(), seeds.end(), false);
  mesher.init();
  while (!mesher.is_refinement_done()) {
    if (static_cast<int64_t>(cdt.number_of_vertices()) >= in->max_points) throw Limit_reached();
    if (!mesher.step_by_step_refine_mesh()) break;
  }
  out->time_refine = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  out->opt_stop = "";
  if (in->optimizer == PEER_MESH2_LLOYD) {
    out->opt_stop = smooth<CGAL::Mesh_2::Lloyd_move_2<CDT, Field_sizing>>(
        cdt, seeds, Field_sizing{field}, in->opt_iterations, &out->opt_iterations);
  } else if (in->optimizer == PEER_MESH2_ODT) {
    out->opt_stop =
        smooth<Odt_move_2<CDT, Field_sizing>>(cdt, seeds, Field_sizing{field}, in->opt_iterations,
                                              &out->opt_iterations);
  }
  out->time_optimize = seconds_since(t0);

  // Vertices: the inputs keep their indices, new ones follow in the triangulation's order.
  std::vector<double> xy(in->xy, in->xy + 2 * static_cast<size_t>(in->npts));
  std::vector<int32_t> on_cons(static_cast<size_t>(in->npts), -1);
  int32_t n = in->npts;
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    Vertex_handle vh = v;
    if (index.count(vh)) continue;
    index[vh] = n++;
    xy.push_back(CGAL::to_double(vh->point().x()));
    xy.push_back(CGAL::to_double(vh->point().y()));
    on_cons.push_back(-1);
  }
  // An added vertex on a constraint: walk along the constrained edges to the input points at
  // both ends of its piece; their input constraint is the one it subdivides.
  auto walk = [&](Vertex_handle from, Vertex_handle cur) {
    while (index[cur] >= in->npts) {
      Vertex_handle next = nullptr;
      auto ec = cdt.incident_edges(cur), ee = ec;
      do {
        if (!cdt.is_infinite(*ec) && cdt.is_constrained(*ec)) {
          Face_handle f = ec->first;
          int i = ec->second;
          Vertex_handle a = f->vertex(CDT::ccw(i)), b = f->vertex(CDT::cw(i));
          Vertex_handle other = a == cur ? b : a;
          if (other != from) next = other;
        }
      } while (next == nullptr && ++ec != ee);
      if (next == nullptr) return static_cast<int32_t>(-1);
      from = cur, cur = next;
    }
    return index[cur];
  };
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    Vertex_handle vh = v;
    int32_t id = index[vh];
    if (id < in->npts || !cdt.are_there_incident_constraints(vh)) continue;
    std::vector<Vertex_handle> nb;
    auto ec = cdt.incident_edges(vh), ee = ec;
    do {
      if (!cdt.is_infinite(*ec) && cdt.is_constrained(*ec)) {
        Face_handle f = ec->first;
        int i = ec->second;
        Vertex_handle a = f->vertex(CDT::ccw(i)), b = f->vertex(CDT::cw(i));
        nb.push_back(a == vh ? b : a);
      }
    } while (++ec != ee);
    if (nb.size() != 2) continue;
    int32_t a = walk(vh, nb[0]), b = walk(vh, nb[1]);
    auto it = cons_of.find(std::make_pair(std::min(a, b), std::max(a, b)));
    if (a >= 0 && b >= 0 && it != cons_of.end()) on_cons[static_cast<size_t>(id)] = it->second;
  }
  // The constraint edges, each with the input constraint it subdivides.
  std::vector<int32_t> seg, seg_cons;
  for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
    if (!cdt.is_constrained(*e)) continue;
    int32_t a = index[e->first->vertex(CDT::ccw(e->second))];
    int32_t b = index[e->first->vertex(CDT::cw(e->second))];
    int32_t k = -1;
    if (a < in->npts && b < in->npts) {
      auto it = cons_of.find(std::make_pair(std::min(a, b), std::max(a, b)));
      if (it != cons_of.end()) k = it->second;
    }
    if (k < 0 && a >= in->npts) k = on_cons[static_cast<size_t>(a)];
    if (k < 0 && b >= in->npts) k = on_cons[static_cast<size_t>(b)];
    if (k < 0) throw std::runtime_error("a constraint edge of the mesh subdivides no input constraint");
    seg.push_back(a), seg.push_back(b), seg_cons.push_back(k);
  }
  std::vector<int32_t> tri;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    for (int q = 0; q < 3; ++q) tri.push_back(index[f->vertex(q)]);
  }
  out->npts = n;
  out->xy = copy_out(xy);
  out->on_cons = copy_out(on_cons);
  out->ntri = static_cast<int32_t>(tri.size() / 3);
  out->tri = copy_out(tri);
  out->nseg = static_cast<int32_t>(seg_cons.size());
  out->seg = copy_out(seg);
  out->seg_cons = copy_out(seg_cons);
}

}  // namespace

extern "C" pm_status peer_mesh2_run(const peer_mesh2_input *in, peer_mesh2_result *out,
                                    pm_error *err) {
  if (!out) return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: no result record");
  std::memset(out, 0, sizeof *out);
  out->opt_stop = "";
  if (!in || in->npts < 3 || in->ncons < 3 || !in->xy || !in->cons || !in->size)
    return pm_error_setf(err, PM_ERR_ARG,
                         "CGAL Mesh_2 needs at least 3 boundary points and 3 constraints");
  if (!(in->shape_bound > 0 && in->shape_bound <= 0.125))
    return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: shape bound %g outside (0, 0.125]",
                         in->shape_bound);
  if (!(in->size_factor > 0) || !std::isfinite(in->size_factor))
    return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: size factor %g is not > 0",
                         in->size_factor);
  if (in->max_points < in->npts)
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "CGAL Mesh_2: %d boundary points, more than the cap %d", (int)in->npts,
                         (int)in->max_points);
  if (in->optimizer != PEER_MESH2_NONE && in->opt_iterations < 1)
    return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: optimizer iterations must be >= 1");
  for (int32_t i = 0; i < 2 * in->npts; ++i)
    if (!std::isfinite(in->xy[i]))
      return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: boundary point %d is not finite",
                           (int)(i / 2));
  for (int32_t k = 0; k < 2 * in->ncons; ++k)
    if (in->cons[k] < 0 || in->cons[k] >= in->npts || (k % 2 && in->cons[k] == in->cons[k - 1]))
      return pm_error_setf(err, PM_ERR_ARG, "CGAL Mesh_2: constraint %d is not an edge of two "
                                            "distinct input points", (int)(k / 2));
  try {
    run(in, out);
    return PM_OK;
  } catch (const CDT::Intersection_of_constraints_exception &) {
    peer_mesh2_result_free(out);
    return pm_error_setf(err, PM_ERR_GEOM, "CGAL Mesh_2: two boundary segments cross");
  } catch (const Limit_reached &) {
    peer_mesh2_result_free(out);
    return pm_error_setf(err, PM_ERR_LIMIT,
                         "CGAL Mesh_2 refinement needs more than %d points (the node cap)",
                         (int)in->max_points);
  } catch (const std::bad_alloc &) {
    peer_mesh2_result_free(out);
    return pm_error_setf(err, PM_ERR_NOMEM, "CGAL Mesh_2: out of memory");
  } catch (const std::exception &x) {
    peer_mesh2_result_free(out);
    return pm_error_setf(err, PM_ERR_BACKEND, "CGAL Mesh_2 failed: %s", x.what());
  } catch (...) {
    peer_mesh2_result_free(out);
    return pm_error_setf(err, PM_ERR_BACKEND, "CGAL Mesh_2 failed (unknown exception)");
  }
}

extern "C" void peer_mesh2_result_free(peer_mesh2_result *r) {
  if (!r) return;
  std::free(r->xy);
  std::free(r->on_cons);
  std::free(r->tri);
  std::free(r->seg);
  std::free(r->seg_cons);
  std::memset(r, 0, sizeof *r);
  r->opt_stop = "";
}
