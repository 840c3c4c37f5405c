// 2D constrained Delaunay triangulation through CGAL (see cdt_cgal.h): the face step of the
// connection layer (DESIGN.md, "Connecting nodes", step 2). C++ only behind the extern "C"
// header; every exception is caught here and turned into a pm_error.
//
// Choices that the header's contract fixes:
//   - Intersection tag No_constraint_intersection_requiring_constructions_tag: CGAL's
//     Exact_predicates_tag would *construct* the crossing point of two constraints and insert it
//     as a new vertex, which the contract forbids. With this tag CGAL still splits a constraint
//     at an input point lying on it (no construction needed) but throws
//     Intersection_of_constraints_exception when two constraints cross elsewhere; the kernel
//     (Epick) keeps every predicate exact.
//   - Duplicates are merged here, before CGAL sees them, so that the representative of a group
//     of equal points is always the smallest input index (CGAL would keep whichever copy its
//     spatial sort met last).
//   - Domain marking by nesting parity: a flood from the infinite face in which crossing a
//     constrained edge raises the nesting level by one; odd levels are inside.
#include "common/backends/cdt_cgal.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_face_base_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_data_structure_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <utility>
#include <vector>

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

// Per-face nesting level of the domain marking; -1 until the flood reaches the face.
struct FaceInfo {
  int nesting = -1;
};

using Vb = CGAL::Triangulation_vertex_base_with_info_2<int32_t, K>;
using Fbi = CGAL::Triangulation_face_base_with_info_2<FaceInfo, K>;
using Fb = CGAL::Constrained_triangulation_face_base_2<K, Fbi>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Itag = CGAL::No_constraint_intersection_requiring_constructions_tag;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, Itag>;
using Point = CDT::Point;
using Vertex_handle = CDT::Vertex_handle;
using Face_handle = CDT::Face_handle;

// Exact orientation sign of (a, b, c): +1 left turn, -1 right turn, 0 collinear.
int orient(const double *a, const double *b, const double *c) {
  return static_cast<int>(CGAL::orientation(Point(a[0], a[1]), Point(b[0], b[1]),
                                            Point(c[0], c[1])));
}

// Do the constraint segments [p, q] and [r, s] meet at a point that CGAL would have to
// construct, i.e. a crossing in the interior of both that is not one of the four end points?
// Shared end points, an end point lying on the other segment (a T, which CGAL resolves by
// splitting at that input point) and collinear overlaps (split at input points too) are not
// such crossings. Used only after CGAL has thrown, to name the pair.
bool crossing_needs_construction(const double *p, const double *q, const double *r,
                                 const double *s, const double *xy, int32_t npts) {
  int o1 = orient(p, q, r), o2 = orient(p, q, s);
  int o3 = orient(r, s, p), o4 = orient(r, s, q);
  if (!(o1 * o2 < 0 && o3 * o4 < 0)) return false;
  // A proper crossing exactly at an input point is resolved by splitting both constraints
  // there; only the error path gets here, so the linear scan costs nothing in a normal run.
  for (int32_t i = 0; i < npts; ++i) {
    const double *c = xy + 2 * i;
    if (orient(p, q, c) == 0 && orient(r, s, c) == 0) return false;
  }
  return true;
}

// Flood the faces from the infinite face; crossing a constrained edge raises the level.
// Faces are processed level by level so each face gets the smallest level by which it can be
// reached (a dangling constraint inside a region does not change the region's parity).
void mark_nesting(CDT &cdt) {
  for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info().nesting = -1;
  std::vector<Face_handle> current{cdt.infinite_face()}, next, stack;
  int level = 0;
  while (!current.empty()) {
    next.clear();
    for (Face_handle seed : current) {
      if (seed->info().nesting != -1) continue;
      seed->info().nesting = level;
      stack.assign(1, seed);
      while (!stack.empty()) {
        Face_handle f = stack.back();
        stack.pop_back();
        for (int i = 0; i < 3; ++i) {
          Face_handle n = f->neighbor(i);
          if (n->info().nesting != -1) continue;
          if (f->is_constrained(i)) {
            next.push_back(n);
          } else {
            n->info().nesting = level;
            stack.push_back(n);
          }
        }
      }
    }
    std::swap(current, next);
    ++level;
  }
}

void zero(pm_cdt_result *r) {
  r->ntri = 0;
  r->tri = nullptr;
  r->merged_into = nullptr;
  r->nmerged = 0;
}

}  // namespace

extern "C" void pm_cdt_result_free(pm_cdt_result *result) {
  if (!result) return;
  free(result->tri);
  free(result->merged_into);
  zero(result);
}

extern "C" pm_status pm_cdt_triangulate(const double *xy, int32_t npts, const int32_t *cons,
                                        int32_t ncons, int remove_exterior, int want_merge_map,
                                        pm_cdt_result *result, pm_error *err) {
  if (!result) return pm_error_setf(err, PM_ERR_ARG, "cdt: result is NULL");
  zero(result);
  if (npts < 0) return pm_error_setf(err, PM_ERR_ARG, "cdt: negative point count %d", npts);
  if (ncons < 0)
    return pm_error_setf(err, PM_ERR_ARG, "cdt: negative constraint count %d", ncons);
  if (npts > 0 && !xy) return pm_error_setf(err, PM_ERR_ARG, "cdt: %d points but xy is NULL", npts);
  if (ncons > 0 && !cons)
    return pm_error_setf(err, PM_ERR_ARG, "cdt: %d constraints but cons is NULL", ncons);
  for (int32_t i = 0; i < npts; ++i)
    if (!std::isfinite(xy[2 * i]) || !std::isfinite(xy[2 * i + 1]))
      return pm_error_setf(err, PM_ERR_ARG, "cdt: point %d has a non-finite coordinate (%g, %g)",
                           i, xy[2 * i], xy[2 * i + 1]);
  for (int32_t k = 0; k < ncons; ++k) {
    int32_t a = cons[2 * k], b = cons[2 * k + 1];
    if (a < 0 || a >= npts || b < 0 || b >= npts)
      return pm_error_setf(err, PM_ERR_ARG,
                           "cdt: constraint %d (%d, %d) has a point index outside [0, %d)", k, a,
                           b, npts);
    if (a == b)
      return pm_error_setf(err, PM_ERR_ARG, "cdt: constraint %d joins point %d to itself", k, a);
  }

  int32_t *merged = nullptr;
  int32_t *tri = nullptr;
  int32_t k_inserting = -1;  // the constraint being inserted when CGAL throws
  try {
    // One batch insertion: CGAL sorts the points along a Hilbert curve (spatial_sort) before
    // inserting them, which keeps point location short.
    CDT cdt;
    {
      std::vector<std::pair<Point, int32_t>> pts;
      pts.reserve(static_cast<size_t>(npts));
      for (int32_t i = 0; i < npts; ++i) pts.emplace_back(Point(xy[2 * i], xy[2 * i + 1]), i);
      cdt.insert(pts.begin(), pts.end());
    }

    // Equal points become one vertex whose info is whichever copy CGAL met last. Only when
    // that happened, find the groups of equal points by sorting (x, y, index) and give every
    // vertex the smallest index of its group, as the contract asks.
    std::vector<int32_t> rep(static_cast<size_t>(npts));
    for (int32_t i = 0; i < npts; ++i) rep[i] = i;
    int32_t nmerged = npts - static_cast<int32_t>(cdt.number_of_vertices());
    if (nmerged > 0) {
      struct Key {
        double x, y;
        int32_t i;
      };
      std::vector<Key> keys(static_cast<size_t>(npts));
      for (int32_t i = 0; i < npts; ++i) keys[i] = Key{xy[2 * i], xy[2 * i + 1], i};
      std::sort(keys.begin(), keys.end(), [](const Key &a, const Key &b) {
        if (a.x != b.x) return a.x < b.x;
        if (a.y != b.y) return a.y < b.y;
        return a.i < b.i;
      });
      for (size_t j = 1; j < keys.size(); ++j)
        if (keys[j].x == keys[j - 1].x && keys[j].y == keys[j - 1].y)
          rep[keys[j].i] = rep[keys[j - 1].i];
      for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v)
        v->info() = rep[v->info()];
    }

    std::vector<Vertex_handle> vh(static_cast<size_t>(npts));
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v)
      vh[v->info()] = v;

    for (int32_t k = 0; k < ncons; ++k) {
      int32_t a = rep[cons[2 * k]], b = rep[cons[2 * k + 1]];
      // Both ends merged into one point: a zero-length constraint constrains nothing.
      if (a == b) continue;
      k_inserting = k;
      cdt.insert_constraint(vh[a], vh[b]);
    }
    k_inserting = -1;

    std::vector<int32_t> out;
    if (cdt.dimension() == 2) {
      if (remove_exterior) mark_nesting(cdt);
      out.reserve(3 * static_cast<size_t>(cdt.number_of_faces()));
      for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
        if (remove_exterior && f->info().nesting % 2 != 1) continue;
        // CGAL's faces are counter-clockwise (vertex 0, 1, 2 turn left).
        for (int i = 0; i < 3; ++i) out.push_back(f->vertex(i)->info());
      }
    }

    size_t ntri = out.size() / 3;
    if (ntri > 0) {
      tri = static_cast<int32_t *>(malloc(out.size() * sizeof(int32_t)));
      if (!tri) throw std::bad_alloc();
      std::memcpy(tri, out.data(), out.size() * sizeof(int32_t));
    }
    if (want_merge_map && npts > 0) {
      merged = static_cast<int32_t *>(malloc(static_cast<size_t>(npts) * sizeof(int32_t)));
      if (!merged) throw std::bad_alloc();
      std::memcpy(merged, rep.data(), static_cast<size_t>(npts) * sizeof(int32_t));
    }
    result->ntri = static_cast<int32_t>(ntri);
    result->tri = tri;
    result->merged_into = merged;
    result->nmerged = nmerged;
    return PM_OK;
  } catch (const CDT::Intersection_of_constraints_exception &) {
    free(tri);
    free(merged);
    // Name the pair: the constraint being inserted crosses one inserted before it.
    int32_t k = k_inserting;
    if (k >= 0) {
      const double *p = xy + 2 * cons[2 * k], *q = xy + 2 * cons[2 * k + 1];
      for (int32_t j = 0; j < k; ++j) {
        const double *r = xy + 2 * cons[2 * j], *s = xy + 2 * cons[2 * j + 1];
        if (crossing_needs_construction(p, q, r, s, xy, npts))
          return pm_error_setf(err, PM_ERR_GEOM,
                               "cdt: constraint edges %d (points %d-%d) and %d (points %d-%d) "
                               "cross away from any input point",
                               j, cons[2 * j], cons[2 * j + 1], k, cons[2 * k], cons[2 * k + 1]);
      }
      return pm_error_setf(err, PM_ERR_GEOM,
                           "cdt: constraint edge %d (points %d-%d) crosses an earlier constraint "
                           "away from any input point",
                           k, cons[2 * k], cons[2 * k + 1]);
    }
    return pm_error_setf(err, PM_ERR_GEOM, "cdt: constraint edges cross away from any input point");
  } catch (const std::bad_alloc &) {
    free(tri);
    free(merged);
    return pm_error_setf(err, PM_ERR_NOMEM, "cdt: out of memory triangulating %d points", npts);
  } catch (const std::exception &e) {
    free(tri);
    free(merged);
    return pm_error_setf(err, PM_ERR_BACKEND, "cdt: CGAL failed: %s", e.what());
  } catch (...) {
    free(tri);
    free(merged);
    return pm_error_setf(err, PM_ERR_BACKEND, "cdt: CGAL failed with an unknown exception");
  }
}
