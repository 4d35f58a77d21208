/*
 * crt_rhs.h: the right-hand side the integrators step -- the model's flight equations
 * (model_rhs: E1.2, E1.7, E1.8 or a reduced model's), or, where S is held on the plane,
 * the contact's (crt_contact_rhs: crt_smooth.h, crt_rough.h).
 *
 * Hand-written C: this file is templates/runtime/crt_rhs.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_RHS_H
#define CRT_RHS_H

#include "crt_contact.h"

/* dq/dt at (t, q) in the session's phase; counts the evaluation */
static void crt_rhs(crt_session *s, double t, const double *q, double *dq)
{
  const double *u = crt_u(s, t);
  ++s->stat[CRT_STAT_RHS_EVALUATIONS];
  if (crt_contact_rhs(s, t, u, q, dq)) return;
  model_rhs(s->prm, u, q, dq);
}

#endif /* CRT_RHS_H */
