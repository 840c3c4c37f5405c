/* Five-number summaries and the sort behind them, for every figure packmesh prints over a
 * set of values (element measures, distances, times over seeds).
 *
 * Summaries: min, p25, median, p75, max, mean. Percentiles use linear interpolation between
 * order statistics: with the n values sorted as x_0 <= ... <= x_{n-1} and h = (n - 1) p, the
 * p-quantile is x_floor(h) + (h - floor(h)) (x_floor(h)+1 - x_floor(h)) (Hyndman & Fan's type 7,
 * the default of R, NumPy and gnuplot's stats), so p25 of {1, 2, 3, 4} is 1.75.
 */
#ifndef PM_SUMMARY_H
#define PM_SUMMARY_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* pm_summary, the five-number summary and the mean of n values, is a type of the public API
 * (packmesh.h). */

/* The p-quantile (0 <= p <= 1) of n >= 1 sorted values, by the convention above. */
double pm_percentile_sorted(const double *sorted, size_t n, double p);

/* Summarize n values (unsorted; not modified). NaN values are skipped and not counted in n. */
pm_status pm_summary_compute(const double *v, size_t n, pm_summary *out, pm_error *err);

/* Sort n doubles ascending (no NaN among them) in O(n) (a radix sort on their bit patterns). */
pm_status pm_sort_doubles(double *v, size_t n, pm_error *err);

#ifdef __cplusplus
}
#endif

#endif /* PM_SUMMARY_H */
