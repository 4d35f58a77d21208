/*
 * crt_law.h: the point law at run time -- an interpreted program (value and two
 * derivatives in one forward pass) or a cubic spline through samples.  Included by each
 * model's runtime (model_<kind>.c).
 *
 * Hand-written C: this file is templates/runtime/crt_law.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 */
#ifndef CRT_LAW_H
#define CRT_LAW_H

#include <math.h>

#include "crt_abi.h"
#include "crt_math.h"          /* crt_sincos */

/* The law as the caller gave it: pointers to the caller's arrays (the session never
   copies or frees them; they must outlive the runs). */
typedef struct {
  int kind;                    /* CRT_LAW_PROGRAM or CRT_LAW_TABLE; -1: not set */
  /* program: n_nodes rows (op, a, b); the first n_const nodes are constants */
  int n_nodes, n_const;
  const int *code;
  const double *consts;
  int out[3];                  /* the nodes of x, y, z */
  /* table: knots[0..n_knots-1], coefficients [(n_knots - 1)][3][4] (c0 s^3 + ... + c3) */
  int n_knots;
  const double *knots;
  const double *coef;
  int periodic;
  int extend;                  /* beyond the last knot: 1 the last cubic goes on (a
                                  controller's law, crt_control.h), 0 the end is held */
} crt_law;

/* Workspace: the jets (value, first, second derivative) of every node, and the last
   evaluation (an integrator evaluates the law at the same time more than once). */
typedef struct {
  int valid;
  double t;
  double u[9];
  int interval;                /* table: the interval of the last evaluation */
  double jet[CRT_LAW_MAX_NODES][3];
} crt_law_work;

/* f, f', f'' of an elementary function at x */
static void crt_law_unary(int op, double x, double *f)
{
  switch (op) {
    case CRT_OP_SIN: { double s, c; crt_sincos(x, &s, &c); f[0] = s; f[1] = c; f[2] = -s; break; }
    case CRT_OP_COS: { double s, c; crt_sincos(x, &s, &c); f[0] = c; f[1] = -s; f[2] = -c; break; }
    case CRT_OP_TAN: {
      const double tn = tan(x), sec2 = 1.0 + tn * tn;
      f[0] = tn; f[1] = sec2; f[2] = 2.0 * tn * sec2; break;
    }
    case CRT_OP_EXP: { const double e = exp(x); f[0] = e; f[1] = e; f[2] = e; break; }
    case CRT_OP_LOG: { const double r = 1.0 / x; f[0] = log(x); f[1] = r; f[2] = -r * r; break; }
    case CRT_OP_SQRT: { const double r = sqrt(x); f[0] = r; f[1] = 0.5 / r; f[2] = -0.25 / (r * x); break; }
    case CRT_OP_SINH: { const double s = sinh(x), c = cosh(x); f[0] = s; f[1] = c; f[2] = s; break; }
    case CRT_OP_COSH: { const double s = sinh(x), c = cosh(x); f[0] = c; f[1] = s; f[2] = c; break; }
    case CRT_OP_TANH: {
      const double th = tanh(x), d = 1.0 - th * th;
      f[0] = th; f[1] = d; f[2] = -2.0 * th * d; break;
    }
    case CRT_OP_ASIN: case CRT_OP_ACOS: {
      const double w = 1.0 - x * x, r = 1.0 / sqrt(w), sg = op == CRT_OP_ASIN ? 1.0 : -1.0;
      f[0] = op == CRT_OP_ASIN ? asin(x) : acos(x); f[1] = sg * r; f[2] = sg * x * r / w; break;
    }
    case CRT_OP_ATAN: {
      const double w = 1.0 / (1.0 + x * x);
      f[0] = atan(x); f[1] = w; f[2] = -2.0 * x * w * w; break;
    }
    default: f[0] = f[1] = f[2] = NAN; break;
  }
}

/* constants' jets, once when the law is set */
static void crt_law_prepare(const crt_law *L, crt_law_work *w)
{
  int k;
  w->valid = 0;
  w->interval = 0;
  if (L->kind != CRT_LAW_PROGRAM) return;
  for (k = 0; k < L->n_const; ++k) {
    w->jet[k][0] = L->consts[L->code[3 * k + 1]];
    w->jet[k][1] = 0.0;
    w->jet[k][2] = 0.0;
  }
}

static void crt_law_program(const crt_law *L, crt_law_work *w, double t, double *u)
{
  double (*J)[3] = w->jet;
  double trig_s = 0.0, trig_c = 1.0;
  int k, c, trig_arg = -1;
  for (k = L->n_const; k < L->n_nodes; ++k) {
    const int op = L->code[3 * k], a = L->code[3 * k + 1], b = L->code[3 * k + 2];
    double *r = J[k];
    switch (op) {
      case CRT_OP_T: r[0] = t; r[1] = 1.0; r[2] = 0.0; break;
      case CRT_OP_HSIN: case CRT_OP_HCOS: {
        /* A sin|cos(w t + p): one sine and cosine for the value and both derivatives */
        const double A = L->consts[a], w = L->consts[a + 1];
        const double th = w * t + L->consts[a + 2];
        double sv, cv;
        const double Aw = A * w, Aww = A * w * w;
        crt_sincos(th, &sv, &cv);
        if (op == CRT_OP_HSIN) { r[0] = A * sv; r[1] = Aw * cv; r[2] = -Aww * sv; }
        else { r[0] = A * cv; r[1] = -Aw * sv; r[2] = -Aww * cv; }
        break;
      }
      case CRT_OP_ADD: r[0] = J[a][0] + J[b][0]; r[1] = J[a][1] + J[b][1]; r[2] = J[a][2] + J[b][2]; break;
      case CRT_OP_SUB: r[0] = J[a][0] - J[b][0]; r[1] = J[a][1] - J[b][1]; r[2] = J[a][2] - J[b][2]; break;
      case CRT_OP_NEG: r[0] = -J[a][0]; r[1] = -J[a][1]; r[2] = -J[a][2]; break;
      case CRT_OP_MUL: {
        const double *x = J[a], *y = J[b];
        r[0] = x[0] * y[0];
        r[1] = x[1] * y[0] + x[0] * y[1];
        r[2] = x[2] * y[0] + 2.0 * x[1] * y[1] + x[0] * y[2];
        break;
      }
      case CRT_OP_DIV: {
        const double *x = J[a], *y = J[b];
        const double inv = 1.0 / y[0], q = x[0] * inv, dq = (x[1] - q * y[1]) * inv;
        r[0] = q; r[1] = dq; r[2] = (x[2] - 2.0 * dq * y[1] - q * y[2]) * inv;
        break;
      }
      case CRT_OP_POWI: case CRT_OP_POWR: {
        const double *x = J[a], n = L->consts[b];
        const double p2 = pow(x[0], n - 2.0), p1 = p2 * x[0], p0 = p1 * x[0];
        const double f1 = n * p1, f2 = n * (n - 1.0) * p2;
        r[0] = p0; r[1] = f1 * x[1]; r[2] = f2 * x[1] * x[1] + f1 * x[2];
        break;
      }
      case CRT_OP_POW: {
        const double *x = J[a], *y = J[b];
        const double lx = log(x[0]), e = exp(y[0] * lx), ix = 1.0 / x[0];
        const double u1 = y[1] * lx + y[0] * x[1] * ix;
        const double u2 = y[2] * lx + 2.0 * y[1] * x[1] * ix
                          + y[0] * (x[2] * ix - x[1] * x[1] * ix * ix);
        r[0] = e; r[1] = e * u1; r[2] = e * (u2 + u1 * u1);
        break;
      }
      case CRT_OP_SIN: case CRT_OP_COS: {
        /* sin and cos of one argument together, and kept for the next node of the same
           argument (a cos(w t) + b sin(w t) evaluates them once) */
        const double *x = J[a];
        double f[3];
        if (a != trig_arg) { crt_sincos(x[0], &trig_s, &trig_c); trig_arg = a; }
        if (op == CRT_OP_SIN) { f[0] = trig_s; f[1] = trig_c; f[2] = -trig_s; }
        else { f[0] = trig_c; f[1] = -trig_s; f[2] = -trig_c; }
        r[0] = f[0]; r[1] = f[1] * x[1]; r[2] = f[2] * x[1] * x[1] + f[1] * x[2];
        break;
      }
      default: {
        double f[3];
        const double *x = J[a];
        crt_law_unary(op, x[0], f);
        r[0] = f[0]; r[1] = f[1] * x[1]; r[2] = f[2] * x[1] * x[1] + f[1] * x[2];
        break;
      }
    }
  }
  for (c = 0; c < 3; ++c) {
    const double *j = J[L->out[c]];
    u[c] = j[0]; u[3 + c] = j[1]; u[6 + c] = j[2];
  }
}

static void crt_law_table(const crt_law *L, crt_law_work *w, double t, double *u)
{
  const double t0 = L->knots[0], t1 = L->knots[L->n_knots - 1];
  int i = w->interval, c;
  double s;
  if (L->periodic) {
    const double period = t1 - t0;
    double tt = t0 + fmod(t - t0, period);
    if (tt < t0) tt += period;
    if (tt >= t1) tt = t0;
    t = tt;
  } else if (t < t0) {
    t = t0;
  } else if (t > t1 && !L->extend) {
    t = t1;
  }
  if (!(i >= 0 && i < L->n_knots - 1 && L->knots[i] <= t && t < L->knots[i + 1])) {
    int lo = 0, hi = L->n_knots - 1;
    while (hi - lo > 1) {
      const int mid = lo + (hi - lo) / 2;
      if (L->knots[mid] <= t) lo = mid; else hi = mid;
    }
    i = lo;
    w->interval = i;
  }
  s = t - L->knots[i];
  for (c = 0; c < 3; ++c) {
    const double *k = L->coef + 12L * i + 4 * c;
    u[c] = ((k[0] * s + k[1]) * s + k[2]) * s + k[3];
    u[3 + c] = (3.0 * k[0] * s + 2.0 * k[1]) * s + k[2];
    u[6 + c] = 6.0 * k[0] * s + 2.0 * k[1];
  }
}

/* The first knot of a table law after t (beyond a margin of rounding), in run time; +inf
   for a program law or past the end of a table that does not repeat.  Steps end on the
   knots: there the spline's third derivative jumps, and a step across one is rejected
   by the error control (about four times per knot). */
static double crt_law_next_knot(const crt_law *L, double t)
{
  const int n = L->n_knots;
  double t0, t1, base = 0.0, tt = t, margin;
  int lo, hi;
  if (L->kind != CRT_LAW_TABLE) return HUGE_VAL;
  t0 = L->knots[0];
  t1 = L->knots[n - 1];
  if (L->periodic) {
    base = (t1 - t0) * floor((t - t0) / (t1 - t0));
    tt = t - base;
  } else if (t >= t1) {
    return HUGE_VAL;
  }
  margin = 1e-12 * (fabs(t) + (t1 - t0));
  if (tt + margin < t0) return base + t0;
  if (tt + margin >= t1)
    return L->periodic ? base + (t1 - t0) + L->knots[1] : HUGE_VAL;
  lo = 0;
  hi = n - 1;                  /* knots[lo] <= tt + margin < knots[hi] */
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    if (L->knots[mid] <= tt + margin) lo = mid; else hi = mid;
  }
  return base + L->knots[hi];
}

/* u = (x, y, z, x', y', z', x'', y'', z'') at t; the last value is reused */
static const double *crt_law_eval(const crt_law *L, crt_law_work *w, double t, long *count)
{
  if (w->valid && w->t == t) return w->u;
  ++*count;
  if (L->kind == CRT_LAW_TABLE) crt_law_table(L, w, t, w->u);
  else crt_law_program(L, w, t, w->u);
  w->t = t;
  w->valid = 1;
  return w->u;
}

#endif /* CRT_LAW_H */
