/*
 * ctl_timing.c: the controller timed call by call, for `derive control` and
 * `derive bench control` (not part of the controller: it needs POSIX's clock_gettime).
 *
 * Hand-written C: this file is templates/control/ctl_timing.c; derive compiles it beside
 * controller.c into the library it loads, and never writes it into the output folder.
 *
 * The time is the calling thread's CPU time (CLOCK_THREAD_CPUTIME_ID): what the solve
 * costs, not what a busy machine's scheduler adds to it.
 *
 * ctl_timed_controller has the controller's signature; its ctx is a ctl_timed whose
 * inner is the controller's own memory.  For each call that ran the solver (a re-plan,
 * or a QP without a solution) it writes a row of CTL_LOG_COLUMNS: the call's time, the
 * seconds the call took, 1 if its QP failed (the law in use went on), 1 if its law meets
 * the end conditions only in part (softened), and its last QP's iterations;
 * and for each law it set, a row of the laws' log: the call's time, n_knots, the knots
 * and the coefficients (CTL_KNOTS + 2 + (CTL_KNOTS - 1) * 12 numbers).
 */
#define _POSIX_C_SOURCE 199309L
#include <time.h>

#include "controller.h"

typedef struct {
  void *inner;              /* the controller's memory (ctl_sizeof() bytes) */
  double *log;              /* rows of CTL_LOG_COLUMNS */
  int cap, n;
  double *laws;             /* rows of CTL_LAW_ROW */
  int laws_cap, laws_n;
} ctl_timed;

#define CTL_LAW_ROW (CTL_KNOTS + 2 + (CTL_KNOTS - 1) * 12)

int ctl_law_row(void) { return CTL_LAW_ROW; }

int ctl_timed_sizeof(void) { return (int)sizeof(ctl_timed); }

int ctl_timed_nstats(void) { return CTL_NSTATS; }

#define CTL_LOG_COLUMNS 5

int ctl_log_columns(void) { return CTL_LOG_COLUMNS; }

int ctl_timed_controller(void *ctx, const crt_call *call, int max_knots, int *n_knots,
                         double *knots, double *coef)
{
  ctl_timed *tc = (ctl_timed *)ctx;
  struct timespec a, b;
  long before[CTL_NSTATS], after[CTL_NSTATS];
  int r;
  ctl_stats(tc->inner, before);
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
  r = ctl_controller(tc->inner, call, max_knots, n_knots, knots, coef);
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
  ctl_stats(tc->inner, after);
  if ((after[CTL_STAT_REPLANS] != before[CTL_STAT_REPLANS]
       || after[CTL_STAT_FAILURES] != before[CTL_STAT_FAILURES]) && tc->n < tc->cap) {
    double *row = tc->log + CTL_LOG_COLUMNS * tc->n++;
    row[0] = call->t;
    row[1] = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
    row[2] = after[CTL_STAT_FAILURES] != before[CTL_STAT_FAILURES];
    row[3] = after[CTL_STAT_SOFTENED] != before[CTL_STAT_SOFTENED];
    row[4] = (double)after[CTL_STAT_LAST_ITERATIONS];
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
