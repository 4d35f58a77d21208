/*
 * crt_friction_state.h: what a session of a friction model (MODEL_FRICTION, the `rough`
 * model) keeps about Coulomb friction at S besides the state: the contact mode and the
 * slip direction of reference.  Included by crt_core.h before the session type; the code
 * is crt_friction.h.
 *
 * Hand-written C: this file is templates/runtime/crt_friction_state.h, copied verbatim into
 * generated/runtime/ by `derive emit`.  Edit it there, then run `derive emit`.
 */
#ifndef CRT_FRICTION_STATE_H
#define CRT_FRICTION_STATE_H

#define CRT_DK_N 7            /* Darboux-Keller's state: v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t */

/* the slip stage's rates in polar coordinates (crt_friction.h; crt_rk_steps.h steps them) */
static void crt_dk_rate(const double *w6, double mu, int log_rho, double x, const double *y,
                        double *dy);

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
} crt_friction;

#endif /* CRT_FRICTION_STATE_H */
