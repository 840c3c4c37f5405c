/* The readable quality table (quality_table.h). */
#include "common/report/quality_table.h"

static void row(FILE *f, const char *name, const pm_summary *s) {
  fprintf(f, "  %-18s %11.6g %11.6g %11.6g %11.6g %11.6g %11.6g\n", name, s->min, s->p25,
          s->median, s->p75, s->max, s->mean);
}

void pm_quality_table_write(FILE *f, const char *geometry, const pm_stats *st,
                            const pm_quality *q, const pm_check_report *r, const pm_needles *nd,
                            const pm_distance *d) {
  fprintf(f, "mesh       %s\n", st->input);
  if (geometry) fprintf(f, "geometry   %s\n", geometry);
  fprintf(f, "elements   %ld nodes, %ld segments, %ld triangles, %ld tetrahedra\n",
          (long)st->nodes, (long)st->segments, (long)st->triangles, (long)st->tets);
  fprintf(f, "valid      %s\n", r->valid ? "yes" : "no");
  for (int32_t i = 0; i < r->nproblem; ++i) fprintf(f, "  problem: %s\n", r->problem[i]);
  for (int32_t i = 0; i < r->nshell; ++i) {
    const pm_check_shell *s = &r->shell[i];
    if (s->triangles == 0) continue;
    if (s->volume >= 0)
      fprintf(f, "volume %-3d ", s->volume);
    else
      fprintf(f, "surface    ");
    fprintf(f, "V - E + F = %lld, %d component%s, %s", (long long)s->euler,
            s->components, s->components == 1 ? "" : "s", s->closed ? "closed" : "open");
    if (s->genus >= 0) fprintf(f, ", genus %d", s->genus);
    fputc('\n', f);
  }
  const pm_kind_quality *k[2] = {&q->tri, &q->tet};
  static const char *const title[2] = {"triangles", "tetrahedra"};
  static const char *const ang[2][2] = {{"min angle (deg)", "max angle (deg)"},
                                        {"min dihedral (deg)", "max dihedral (deg)"}};
  for (int j = 0; j < 2; ++j) {
    if (k[j]->n == 0) continue;
    fprintf(f, "\n%-20s %11s %11s %11s %11s %11s %11s\n", title[j], "min", "p25", "median",
            "p75", "max", "mean");
    row(f, "radius ratio", &k[j]->s_radius_ratio);
    row(f, "aspect ratio", &k[j]->s_aspect_ratio);
    row(f, ang[j][0], &k[j]->s_min_angle);
    row(f, ang[j][1], &k[j]->s_max_angle);
    if (k[j]->eps_t_nodes > 0)
      fprintf(f, "  eps_t %.6g over %ld interior nodes, eps_g %.6g\n", k[j]->eps_t,
              (long)k[j]->eps_t_nodes, k[j]->eps_g);
    else
      fprintf(f, "  eps_t: no interior nodes, eps_g %.6g\n", k[j]->eps_g);
    if (k[j]->has_size)
      fprintf(f, "  edge length / size: mean %.6g, std %.6g over %lld edges\n",
              k[j]->size_ratio.mean, k[j]->size_ratio_std, (long long)k[j]->nedge);
    if (k[j]->degenerate) fprintf(f, "  degenerate: %ld\n", (long)k[j]->degenerate);
    if (j == 0) {
      const int64_t *b = q->tri_min_angle_bins, *o = q->tri_max_angle_over;
      fprintf(f,
              "  min angle in [0,10) %lld  [10,20) %lld  [20,30) %lld  [30,40) %lld  "
              "[40,50) %lld  [50,60] %lld\n",
              (long long)b[0], (long long)b[1], (long long)b[2], (long long)b[3],
              (long long)b[4], (long long)b[5]);
      fprintf(f, "  max angle > 90 %lld  > 120 %lld  > 150 %lld\n", (long long)o[0],
              (long long)o[1], (long long)o[2]);
      fprintf(f, "  needles (an angle below %g deg): %lld, forced %lld (sharp corners %lld, "
                 "features below the floor %lld), unforced %lld\n",
              PM_NEEDLE_DEG, (long long)nd->count, (long long)(nd->corner + nd->feature),
              (long long)nd->corner, (long long)nd->feature, (long long)nd->unforced);
      const pm_summary *a = q->tri_site_aspect;
      fprintf(f, "  triangles by site: boundary %lld, irregular %lld, regular %lld\n",
              (long long)a[PM_TRI_BOUNDARY].n, (long long)a[PM_TRI_IRREGULAR].n,
              (long long)a[PM_TRI_REGULAR].n);
      for (int w = 0; w < PM_TRI_SITES; ++w) {
        if (a[w].n == 0) continue;
        char name[40];
        snprintf(name, sizeof name, "R/l_min %s", pm_tri_site_name((pm_tri_site)w));
        row(f, name, &a[w]);
      }
    }
  }
  if (d) {
    fprintf(f, "\ndistance   mean %.6g, max %.6g (model diagonal %.6g)\n", d->mean, d->max,
            d->bbox_diagonal);
    if (d->has_size)
      fprintf(f, "           relative to the size field: mean %.6g, max %.6g\n", d->rel_mean,
              d->rel_max);
  }
  fprintf(f, "\ntime       %.3f s\n", st->time_total);
}
