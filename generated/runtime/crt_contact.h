/*
 * crt_contact.h: the contact with the plane, chosen once by the model's macros --
 * crt_rough.h (MODEL_FRICTION: Coulomb friction at S), crt_smooth.h (MODEL_HAS_PLANE: the
 * smooth plane), or, for a model without the plane, the three hooks that free flight reads.
 *
 * Hand-written C: this file is templates/runtime/crt_contact.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * Every variant defines the hooks the runtime calls (crt_rhs.h, crt_events.h, crt_loop.h,
 * crt_core.h):
 *   crt_contact_rhs(s, t, u, q, dq)         dq/dt where S is held on the plane: 1, else 0
 *   crt_contact_start(s)                    crt_init: the contact's memory set
 *   crt_contact_due(s, o)                   a transition due at a step's start: applied
 *                                           (enum crt_due)
 * and, with the plane:
 *   crt_contact_event_value(s, t, y, d)     the event function in contact (d: its rate)
 *   crt_contact_kinked(s)                   1 when that function has kinks (crt_root)
 *   crt_contact_enter(s, o, t, v_cut, t_a)  enter persistent contact
 *   crt_contact_impact(s, o, t, v_n, q+, v+) an impact: the state after, 0 when refused
 *   crt_contact_transition(s, o, t)         the event function reached 0 inside a step
 *   crt_contact_after_step(s)               after an accepted step: 0 when it is refused
 */
#ifndef CRT_CONTACT_H
#define CRT_CONTACT_H

#if MODEL_FRICTION
#include "crt_rough.h"
#elif MODEL_HAS_PLANE
#include "crt_smooth.h"
#else
#include "crt_session.h"

/* no plane: never in contact */
static int crt_contact_rhs(crt_session *s, double t, const double *u, const double *q,
                           double *dq)
{
  (void)s; (void)t; (void)u; (void)q; (void)dq;
  return 0;
}

static void crt_contact_start(crt_session *s)
{
  (void)s;
}

static int crt_contact_due(crt_session *s, crt_out *o)
{
  (void)s; (void)o;
  return CRT_DUE_NONE;
}
#endif

#endif /* CRT_CONTACT_H */
