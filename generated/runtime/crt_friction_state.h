/*
 * crt_friction_state.h: what a session of a friction model (MODEL_FRICTION, the `rough`
 * model) keeps about Coulomb friction at S besides the state: the contact mode and the
 * slip direction of reference.  Included by crt_session.h before the session type; the
 * code is crt_rough_modes.h and crt_rough.h.
 *
 * Hand-written C: this file is templates/runtime/crt_friction_state.h, copied verbatim into
 * generated/runtime/ by `derive emit`.  Edit it there, then run `derive emit`.
 */
#ifndef CRT_FRICTION_STATE_H
#define CRT_FRICTION_STATE_H

/* A couple's channel (spin friction: 1 component, Omega_Z; rolling resistance: 2,
   Omega_X and Omega_Y), with the slip's fields below in its own angular units. */
typedef struct {
  int on;                     /* its coefficient (mu_s or mu_r) is > 0 */
  int held;                   /* its angular velocity held at 0 by a couple inside the bound */
  double dir[2];              /* turning: the direction of reference (unit; spin: dir[0] is
                                 +-1), as the slip's dir */
  int armed;                  /* as the slip's */
  double w_eps, w_arm, w_freeze, w_scale;   /* as v_eps, v_arm, v_freeze, v_scale */
} crt_channel;

typedef struct {
  int mode;                   /* in contact: CRT_MODE_SLIDING or CRT_MODE_STICKING */
  double dir[2];              /* sliding: the slip direction of reference (unit, fixed
                                 axes): the slip's at the last step's end, or -R_t/|R_t|
                                 where the slip restarts from 0 */
  int armed;                  /* sliding: the slip is resolved (above v_arm) along dir:
                                 the friction follows the slip, and the event "the slip
                                 reaches 0" (v_t . dir = 0) is searched */
  double v_eps;               /* slips below this are round-off (set entering a mode) */
  double v_arm;               /* slips above this are resolved by the integrator */
  double v_freeze;            /* below this the friction keeps the reference direction */
  double v_scale;             /* the slip's scale there (the event function's unit) */
  int couples;                /* spin friction or rolling resistance is on: the contact is
                                 solved as a wrench (crt_rough_wrench) */
  crt_channel spin, roll;
} crt_friction;

#endif /* CRT_FRICTION_STATE_H */
