/*
 * crt_call.h: the ABI of a controller of the closed loop (crt_control.h) -- what the
 * runtime hands it at each call and the function it calls.  A controller compiled apart
 * from the runtime (a generated controller.c) includes only this header.
 *
 * Hand-written C: this file is templates/runtime/crt_call.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_CALL_H
#define CRT_CALL_H

#ifdef __cplusplus
extern "C" {
#endif

/* What the runtime hands a controller at each call.  A controller's own header may
   declare the same struct (tag crt_call, these members) under the same guard: a
   generated controller's controller.h does, so that it compiles without the runtime. */
#ifndef CRT_CALL_DEFINED
#define CRT_CALL_DEFINED
typedef struct crt_call {
  double t;                 /* the time of the call */
  int reason;               /* 0 start, 1 sample, 2 event (enum crt_call_reason) */
  int event;                /* a call at an event: its kind (enum crt_event_kind) */
  int nq;                   /* the model's states */
  const double *q;          /* the state as measured: the run's state plus the noise */
  const double *u;          /* the law at t: x, y, z, x', y', z', x'', y'', z'' */
  long k;                   /* the calls before this one */
} crt_call;
#endif

/* A controller: reads call, returns 0 (the law goes on), 1 (a new law from call->t:
   n_knots knots (2 to max_knots), knots[0] = call->t, coef[(n_knots - 1) * 12] the cubic
   of x, y, z on each interval, c0 s^3 + c1 s^2 + c2 s + c3 with s = t - knot; its value
   and rate at call->t those of call->u), or a negative value (the run stops).  ctx is the
   controller's own memory. */
typedef int (*crt_controller_fn)(void *ctx, const crt_call *call, int max_knots,
                                 int *n_knots, double *knots, double *coef);

#ifdef __cplusplus
}
#endif

#endif /* CRT_CALL_H */
