/*
 * crt_hop.h: per-hop feedback as a C controller of the closed loop (crt_hop.c): its
 * memory and its entry points.  Include this header and crt_call.h; link crt_hop.c (the
 * CMake target carrier::hop) and libm.
 *
 *   crt_hop_params P = {...};                   the design: derive.control.hop.Design
 *   crt_control_setup(&c, crt_hop_controller, &P, 0.0, noise, seed, ...)  in the runtime,
 * or call crt_hop_controller(&P, &call, max_knots, &n, knots, coef) after each impact
 * (call.reason = 2, call.event = 1) in a robot's own loop: it writes the coming hop's law
 * as cubic pieces of the point's z (x, y as they were).
 *
 * Hand-written C: this file is templates/control/crt_hop.h, copied verbatim into
 * generated/control/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.  It includes the controllers' ABI,
 * crt_call.h, from generated/runtime/.
 */
#ifndef CRT_HOP_H
#define CRT_HOP_H

#include "crt_call.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The design (derive.control.hop.Design) and the controller's state. */
typedef struct {
  double K[3];              /* the gain on (phase, velocity, gait before) */
  double t_star, v_star;    /* the orbit's impact time (mod T) and C's velocity after it */
  double a_star, W;         /* the design's gait a* sin(W t) */
  double T, tb, h, limit;   /* the period, the blend, the step of the pieces, the clamp */
  int n;                    /* pieces of a law (n + 1 knots: at most the caller's max) */
  int zd;                   /* where Z_C' sits in the plant model's state */
  double a_prev;            /* the gait of the hop before (the controller's state) */
  double law_end;           /* the end of the law it set last (its state; -HUGE_VAL) */
} crt_hop_params;

/* sizeof(crt_hop_params): a binding checks its own layout against it */
int crt_hop_sizeof(void);

/* The controller (crt_controller_fn of crt_call.h); ctx is a crt_hop_params. */
int crt_hop_controller(void *ctx, const crt_call *call, int max_knots, int *n_knots,
                       double *knots, double *coef);

#ifdef __cplusplus
}
#endif

#endif /* CRT_HOP_H */
