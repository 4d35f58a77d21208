/*
 * crt_rough_api.h: the friction models' own public functions (MODEL_FRICTION, the `rough`
 * model; crt_has_friction() says 1): the contact mode, the contact's equations along rows
 * (the energy balance and the charts read them), a run started in contact, the Delassus
 * matrix, the contact as a wrench, and Darboux-Keller's impact alone.  Included by
 * crt_core.h, whose manual covers the rest of the API.
 *
 * Hand-written C: this file is templates/runtime/crt_rough_api.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_ROUGH_API_H
#define CRT_ROUGH_API_H

#include "crt_rhs.h"

/* the contact mode (enum crt_mode): CRT_MODE_FLIGHT, CRT_MODE_SLIDING or CRT_MODE_STICKING */
int crt_contact_mode(const crt_session *s)
{
  return s->phase == CRT_FLIGHT ? CRT_MODE_FLIGHT : s->fr.mode;
}

/* Along n rows (t[k], q[k*NQ..]) in the modes mode[k] (enum crt_mode; CRT_MODE_SLIDING
   along dir[2k..] (fixed axes, normalised here), or where that is 0 along the slip, or
   (1, 0) where the slip is 0 too; CRT_MODE_STICKING; any other: flight): dq/dt into
   dq[k*NQ..], the reaction at S R[3k..] (fixed axes; 0 in flight) and the velocity of S
   v_S[3k..]. */
void crt_eval_rough_rows(crt_session *s, int n, const double *t, const double *q,
                         const int *mode, const double *dir_in, double *dq, double *R,
                         double *v_S)
{
  const double mu_f = s->prm[CRT_P_friction];
  int k;
  for (k = 0; k < n; ++k) {
    const double *qk = q + (long)k * NQ, *u = crt_u(s, t[k]);
    double *dqk = dq + (long)k * NQ, *Rk = R + 3L * k, *vk = v_S + 3L * k;
    model_contact_velocity(s->prm, u, qk, vk);
    if (mode[k] == CRT_MODE_STICKING) {
      model_sticking(s->prm, u, qk, dqk, Rk);
    } else if (mode[k] == CRT_MODE_SLIDING) {
      const double *d = dir_in + 2L * k;
      const double given = sqrt(d[0] * d[0] + d[1] * d[1]);
      const double rho = sqrt(vk[0] * vk[0] + vk[1] * vk[1]);
      double dir[2], N, v_t[2], a_t[2];
      if (given > 0.0) { dir[0] = d[0] / given; dir[1] = d[1] / given; }
      else {
        dir[0] = rho > 0.0 ? vk[0] / rho : 1.0;
        dir[1] = rho > 0.0 ? vk[1] / rho : 0.0;
      }
      model_sliding(s->prm, u, qk, mu_f, dir, dqk, &N, v_t, a_t);
      Rk[0] = -mu_f * N * dir[0]; Rk[1] = -mu_f * N * dir[1]; Rk[2] = N;
    } else {
      model_rhs(s->prm, u, qk, dqk);
      Rk[0] = Rk[1] = Rk[2] = 0.0;
    }
  }
}

/* As crt_eval_rough_rows with spin friction or rolling resistance: each row's held channels
   couples[k] (bit 1: the spin, bit 2: the rolling; the event column "couples") and the
   turning channels' directions cdir[3k..] (the spin's sign, then the rolling's direction,
   fixed axes; 0: along the angular velocity): dq/dt into dq[k*NQ..], the wrench at S
   w[6k..] = (R, T) (fixed axes; 0 in flight) and u[6k..] = (v_S, A omega). */
void crt_eval_wrench_rows(crt_session *s, int n, const double *t, const double *q,
                          const int *mode, const double *dir_in, const int *couples,
                          const double *cdir, double *dq, double *w, double *u6)
{
  const crt_channel keep[2] = {s->fr.spin, s->fr.roll};
  int k, c, i;
  for (k = 0; k < n; ++k) {
    const double *qk = q + (long)k * NQ, *d = dir_in + 2L * k;
    double *dqk = dq + (long)k * NQ, *wk = w + 6L * k, *uk = u6 + 6L * k, Om[3], dir[2];
    crt_omega_fixed(qk, Om);
    for (c = 0; c < 2; ++c) {
      crt_channel *ch = crt_couple(s, c);
      const int first = crt_couple_first(c) - 3, dim = crt_couple_dim(c);
      const double *dc = cdir + 3L * k + c;
      const double given = crt_norm_of(dim, dc), rho = crt_norm_of(dim, Om + first);
      const double *from = given > 0.0 ? dc : Om + first;
      const double r = given > 0.0 ? given : rho;
      ch->held = (couples[k] >> c) & 1;
      ch->armed = 0;
      ch->dir[0] = r > 0.0 ? from[0] / r : 1.0;
      ch->dir[1] = dim == 2 && r > 0.0 ? from[1] / r : 0.0;
    }
    if (mode[k] == CRT_MODE_STICKING || mode[k] == CRT_MODE_SLIDING) {
      crt_wrench wr;
      const double given = sqrt(d[0] * d[0] + d[1] * d[1]);
      double v[3], rho;
      model_contact_velocity(s->prm, crt_u(s, t[k]), qk, v);
      rho = sqrt(v[0] * v[0] + v[1] * v[1]);
      dir[0] = given > 0.0 ? d[0] / given : rho > 0.0 ? v[0] / rho : 1.0;
      dir[1] = given > 0.0 ? d[1] / given : rho > 0.0 ? v[1] / rho : 0.0;
      crt_rough_wrench(s, t[k], qk, mode[k], dir, dqk, &wr);
      for (i = 0; i < 6; ++i) { wk[i] = wr.w[i]; uk[i] = wr.u[i]; }
    } else {
      model_rhs(s->prm, crt_u(s, t[k]), qk, dqk);
      model_contact_velocity(s->prm, crt_u(s, t[k]), qk, uk);
      for (i = 0; i < 3; ++i) { wk[i] = wk[3 + i] = 0.0; uk[3 + i] = Om[i]; }
    }
  }
  s->fr.spin = keep[0];
  s->fr.roll = keep[1];
}

/* After crt_init (CRT_OK): start the run in contact instead of flight, S held on the
   plane (h = 0 and v_n = 0 are made so), in the mode CRT_MODE_STICKING (the slip is set to
   0) or CRT_MODE_SLIDING along dir[2] (fixed axes; normalised; the slip's own direction
   once it is resolved).  For a run that resumes a contact phase (the energy balance's
   finer rows of a short phase).  Returns CRT_OK, or CRT_BAD_ARGUMENT for another mode or
   a zero dir (the session is then unchanged). */
int crt_set_contact_mode(crt_session *s, int mode, const double *dir)
{
  double v[3];
  if (s->status != CRT_OK) return s->status;
  if (mode != CRT_MODE_SLIDING && mode != CRT_MODE_STICKING) return CRT_BAD_ARGUMENT;
  if (mode == CRT_MODE_SLIDING && !(dir[0] * dir[0] + dir[1] * dir[1] > 0.0))
    return CRT_BAD_ARGUMENT;
  crt_project(s, s->t, s->q, 1);
  s->phase = CRT_CONTACT;
  crt_rough_scales(s, s->t);
  if (s->fr.couples) crt_couples_enter(s);
  s->fr.mode = mode;
  model_contact_velocity(s->prm, crt_u(s, s->t), s->q, v);
  if (mode == CRT_MODE_STICKING) {
    crt_rough_stop_slip(s, s->t, s->q);
  } else {
    const double r = sqrt(dir[0] * dir[0] + dir[1] * dir[1]);
    s->fr.dir[0] = dir[0] / r; s->fr.dir[1] = dir[1] / r;
    s->fr.armed = sqrt(v[0] * v[0] + v[1] * v[1]) > s->fr.v_arm;
  }
  s->last_event_t = s->t;
  crt_changed(s);
  s->g_valid = 0;
  crt_rhs(s, s->t, s->q, s->f);
  s->f_valid = 1;
  return CRT_OK;
}

/* The slip's speeds a contact mode entered at (t, q) sets (crt_rough_band): band[4] =
   (its scale, round-off, resolution v_arm, v_freeze: below v_freeze a sliding friction
   keeps the reference direction the slip had at the start of the step, crt_follow_dir). */
void crt_eval_slip_band(crt_session *s, double t, const double *q, double *band)
{
  crt_rough_band(s, t, q, band);
}

/* The Delassus matrix W (upper triangle w6[6], fixed axes) and the velocity of S v_S[3] at
   (t, q). */
void crt_eval_delassus(crt_session *s, double t, const double *q, double *w6, double *v_S)
{
  model_delassus(s->prm, crt_u(s, t), q, w6, v_S);
}

/* The contact as a wrench at (t, q): G's upper triangle g21[21] (row by row), a_free[6]
   and u6[6] = (v_S, A omega), fixed axes (general_contact_wrench). */
void crt_eval_contact_wrench(crt_session *s, double t, const double *q, double *g21,
                             double *a_free, double *u6)
{
  double w0[3], Yw[18];
  model_contact_wrench(s->prm, crt_u(s, t), q, g21, a_free, u6, w0, Yw);
}

/* Darboux-Keller's impact for W (w6[6]) and the velocity of S v0[3] (v0[2] < 0) with the
   session's mu_f, e, restitution law and tolerance: out[9] = (P_X, P_Y, P_Z, v_X+, v_Y+,
   v_Z+, E_n, E_t, stage).  Returns CRT_OK, CRT_PAINLEVE or CRT_RESTITUTION_REFUSED. */
int crt_eval_impact(const crt_session *s, const double *w6, const double *v0, double *out)
{
  crt_dk_result r;
  int i;
  const int status = crt_dk_impact(w6, v0, s->prm[CRT_P_friction], s->prm[CRT_P_e],
                                   (int)s->prm[CRT_P_restitution_model],
                                   crt_rough_dk_rtol(s), &r);
  for (i = 0; i < 9; ++i) out[i] = 0.0;
  if (status != CRT_OK) return status;
  for (i = 0; i < 3; ++i) { out[i] = r.P[i]; out[3 + i] = r.v[i]; }
  out[6] = r.work_n; out[7] = r.work_t; out[8] = (double)r.stage;
  return CRT_OK;
}

#endif /* CRT_ROUGH_API_H */
