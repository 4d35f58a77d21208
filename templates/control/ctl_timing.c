/*
 * ctl_timing.c: the controller timed call by call, for `derive control` and
 * `derive bench control` (not part of the controller: it needs POSIX's clock_gettime).
 *
 * Hand-written C: this file is templates/control/ctl_timing.c; derive compiles it beside
 * controller.c into the library it loads, and never writes it into the output folder.
 *
 * ctl_timed_controller has the controller's signature; its ctx is a ctl_timed whose
 * inner is the controller's own memory.  For each call that ran the solver (a re-plan,
 * or a QP without a solution) it writes the call's time and the seconds the call took,
 * and for each law it set, a row of the laws' log: the call's time, n_knots, the knots
 * and the coefficients (CTL_KNOTS + 2 + (CTL_KNOTS - 1) * 12 numbers).
 */
#define _POSIX_C_SOURCE 199309L
#include <time.h>

#include "controller.h"

typedef struct {
  void *inner;              /* the controller's memory (ctl_sizeof() bytes) */
  double *log;              /* rows (t, seconds) */
  int cap, n;
  double *laws;             /* rows of CTL_LAW_ROW */
  int laws_cap, laws_n;
} ctl_timed;

#define CTL_LAW_ROW (CTL_KNOTS + 2 + (CTL_KNOTS - 1) * 12)

int ctl_law_row(void) { return CTL_LAW_ROW; }

int ctl_timed_sizeof(void) { return (int)sizeof(ctl_timed); }

int ctl_timed_controller(void *ctx, const crt_call *call, int max_knots, int *n_knots,
                         double *knots, double *coef)
{
  ctl_timed *tc = (ctl_timed *)ctx;
  struct timespec a, b;
  long before[5], after[5];
  int r;
  ctl_stats(tc->inner, before);
  clock_gettime(CLOCK_MONOTONIC, &a);
  r = ctl_controller(tc->inner, call, max_knots, n_knots, knots, coef);
  clock_gettime(CLOCK_MONOTONIC, &b);
  ctl_stats(tc->inner, after);
  if ((after[1] != before[1] || after[2] != before[2]) && tc->n < tc->cap) {
    tc->log[2 * tc->n] = call->t;
    tc->log[2 * tc->n + 1] = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
    ++tc->n;
  }
  if (r == 1 && tc->laws_n < tc->laws_cap && *n_knots <= CTL_KNOTS) {
    double *row = tc->laws + (long)CTL_LAW_ROW * tc->laws_n++;
    int i;
    row[0] = call->t;
    row[1] = *n_knots;
    for (i = 0; i < *n_knots; ++i) row[2 + i] = knots[i];
    for (i = 0; i < (*n_knots - 1) * 12; ++i) row[2 + CTL_KNOTS + i] = coef[i];
  }
  return r;
}
