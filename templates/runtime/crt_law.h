/*
 * crt_law.h: the laws of the internal bodies at run time -- an interpreted program (value
 * and two derivatives of every output in one forward pass) and cubic splines through
 * samples.  Included by each model's runtime (model_<kind>.c).
 *
 * Hand-written C: this file is templates/runtime/crt_law.h, copied verbatim into
 * generated/runtime/ by `derive emit` (`derive emit --check` compares the copy byte for
 * byte).  Edit it there, then run `derive emit`.
 *
 * Three kinds of law (enum crt_law_kind):
 *   CRT_LAW_PROGRAM  one point: its x, y, z are nodes of a program (crt_set_law_program);
 *   CRT_LAW_TABLE    one point: a cubic spline of x, y, z (crt_set_law_table, and the
 *                    controller's laws, crt_control.h);
 *   CRT_LAW_BODIES   n_points points and n_rotors rotors (crt_set_law_bodies): each
 *                    output a node of one program (every formula shares its common
 *                    subexpressions with the others) or a column of one spline (the
 *                    points given as tables, on the union of their knots).
 * What a law gives at t is u (crt_law_eval), CRT_LAW_WIDTH(n_points, n_rotors) numbers:
 * point j at u[9 j ..]: (x, y, z, x', y', z', x'', y'', z''); then rotor r at
 * u[9 n_points + 3 r ..]: (psi, psi', psi'').  One point's u is the first nine.
 */
#ifndef CRT_LAW_H
#define CRT_LAW_H

#include <math.h>

#include "crt_abi.h"
#include "crt_math.h"          /* crt_sincos */

/* the outputs of a law: 3 per point (x, y, z), 1 per rotor (psi) */
#define CRT_LAW_MAX_OUTPUTS (3 * CRT_LAW_MAX_POINTS + CRT_LAW_MAX_ROTORS)
/* the numbers of u: 9 per point (x, y, z and their two derivatives), 3 per rotor */
#define CRT_LAW_WIDTH(n_points, n_rotors) (9 * (n_points) + 3 * (n_rotors))
#define CRT_LAW_MAX_WIDTH CRT_LAW_WIDTH(CRT_LAW_MAX_POINTS, CRT_LAW_MAX_ROTORS)

/* The law as the caller gave it: pointers to the caller's arrays (the session never
   copies or frees them; they must outlive the runs). */
typedef struct {
  int kind;                    /* CRT_LAW_PROGRAM, CRT_LAW_TABLE or CRT_LAW_BODIES; -1:
                                  not set */
  int n_points, n_rotors;      /* the bodies (one point, none, for PROGRAM and TABLE) */
  /* program: n_nodes rows (op, a, b); the first n_const nodes are constants (n_nodes 0:
     no program, a law of tables only) */
  int n_nodes, n_const;
  const int *code;
  const double *consts;
  /* the outputs, 3 n_points + n_rotors in u's order (x, y, z of each point, then psi of
     each rotor): PROGRAM the nodes of x, y, z; BODIES a node (>= 0), or -1 - c for
     column c of the table */
  int out[CRT_LAW_MAX_OUTPUTS];
  /* table: knots[0..n_knots-1], coefficients [(n_knots - 1)][n_columns][4] (c0 s^3 + ...
     + c3); TABLE has the 3 columns x, y, z (n_knots 0 in BODIES: no table) */
  int n_knots, n_columns;
  const double *knots;
  const double *coef;
  int periodic;
  int extend;                  /* beyond the last knot: 1 the last cubic goes on (a
                                  controller's law, crt_control.h), 0 the end is held */
  /* BODIES: a controller's law over up to three of the outputs (crt_control.h,
     crt_control_channels): ctl_n_knots knots (0: none) and 12 coefficients an interval,
     as a TABLE's x, y, z; its column c in place of output ctl_out[c] (-1: none), held at
     its first knot before it, its last cubic going on beyond its end */
  int ctl_n_knots;
  int ctl_out[3];
  const double *ctl_knots;
  const double *ctl_coef;
} crt_law;

/* Workspace: the jets (value, first, second derivative) of every node, and the last
   evaluation (an integrator evaluates the law at the same time more than once). */
typedef struct {
  int valid;
  double t;
  double u[CRT_LAW_MAX_WIDTH];
  int interval;                /* table: the interval of the last evaluation */
  int ctl_interval;            /* the controller's law over bodies: the same */
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
  w->ctl_interval = 0;
  if (L->kind != CRT_LAW_PROGRAM && L->kind != CRT_LAW_BODIES) return;
  for (k = 0; k < L->n_const; ++k) {
    w->jet[k][0] = L->consts[L->code[3 * k + 1]];
    w->jet[k][1] = 0.0;
    w->jet[k][2] = 0.0;
  }
}

/* A program's rules (crt_set_law_program, crt_set_law_bodies): n_nodes (1 to
   CRT_LAW_MAX_NODES) rows (op, a, b) of code, the first n_const of them CRT_OP_CONST and
   no other; each node reads only nodes before it, each constant index is below n_consts.
   1 when the program keeps them, else 0. */
static int crt_law_program_ok(int n_nodes, int n_const, const int *code, int n_consts)
{
  int k;
  if (n_nodes < 1 || n_nodes > CRT_LAW_MAX_NODES || n_const < 0 || n_const > n_nodes)
    return 0;
  for (k = 0; k < n_nodes; ++k) {
    const int op = code[3 * k], a = code[3 * k + 1], b = code[3 * k + 2];
    if (op < 0 || op >= CRT_OP_COUNT || (k < n_const) != (op == CRT_OP_CONST)) return 0;
    if (op == CRT_OP_CONST) { if (a < 0 || a >= n_consts) return 0; continue; }
    if (op == CRT_OP_T) continue;
    if (op == CRT_OP_HSIN || op == CRT_OP_HCOS) {
      if (a < 0 || a + 2 >= n_consts) return 0;
      continue;
    }
    if (a < 0 || a >= k) return 0;
    if ((op == CRT_OP_POWI || op == CRT_OP_POWR) && (b < 0 || b >= n_consts)) return 0;
    if ((op == CRT_OP_ADD || op == CRT_OP_SUB || op == CRT_OP_MUL || op == CRT_OP_DIV
         || op == CRT_OP_POW) && (b < 0 || b >= k))
      return 0;
  }
  return 1;
}

/* crt_set_law_bodies on the law and its workspace (its rules there); CRT_OK or
   CRT_BAD_LAW, which leaves no law (kind -1). */
static int crt_law_set_bodies(crt_law *L, crt_law_work *w, int n_points, int n_rotors,
                              const int *out, int n_nodes, int n_const, const int *code,
                              const double *consts, int n_consts, int n_knots,
                              int n_columns, const double *knots, const double *coef,
                              int periodic)
{
  int k;
  L->kind = -1;
  if (n_points < 0 || n_points > CRT_LAW_MAX_POINTS || n_rotors < 0
      || n_rotors > CRT_LAW_MAX_ROTORS)
    return CRT_BAD_LAW;
  if (n_nodes != 0 && !crt_law_program_ok(n_nodes, n_const, code, n_consts))
    return CRT_BAD_LAW;
  if (n_knots != 0) {
    if (n_knots < 2 || n_columns < 1 || n_columns > CRT_LAW_MAX_OUTPUTS) return CRT_BAD_LAW;
    for (k = 1; k < n_knots; ++k)
      if (!(knots[k] > knots[k - 1])) return CRT_BAD_LAW;
  } else {
    n_columns = 0;
  }
  for (k = 0; k < 3 * n_points + n_rotors; ++k)
    if (out[k] >= n_nodes || out[k] < -n_columns) return CRT_BAD_LAW;
  L->n_points = n_points;
  L->n_rotors = n_rotors;
  L->n_nodes = n_nodes;
  L->n_const = n_nodes ? n_const : 0;
  L->code = code;
  L->consts = consts;
  for (k = 0; k < 3 * n_points + n_rotors; ++k) L->out[k] = out[k];
  L->n_knots = n_knots;
  L->n_columns = n_columns;
  L->knots = knots;
  L->coef = coef;
  L->periodic = periodic != 0;
  L->extend = 0;
  L->ctl_n_knots = 0;
  L->kind = CRT_LAW_BODIES;
  crt_law_prepare(L, w);
  return CRT_OK;
}

/* the numbers of u for the law set (0: none) */
static int crt_law_u_width(const crt_law *L)
{
  if (L->kind == CRT_LAW_PROGRAM || L->kind == CRT_LAW_TABLE) return 9;
  if (L->kind == CRT_LAW_BODIES) return CRT_LAW_WIDTH(L->n_points, L->n_rotors);
  return 0;
}

/* every node's jet at t (the program's forward pass) */
static void crt_law_nodes(const crt_law *L, crt_law_work *w, double t)
{
  double (*J)[3] = w->jet;
  double trig_s = 0.0, trig_c = 1.0;
  int k, trig_arg = -1;
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
}

/* one point's program: u = (x, y, z, x', y', z', x'', y'', z'') */
static void crt_law_program(const crt_law *L, crt_law_work *w, double t, double *u)
{
  const double (*J)[3] = (const double (*)[3])w->jet;
  int c;
  crt_law_nodes(L, w, t);
  for (c = 0; c < 3; ++c) {
    const double *j = J[L->out[c]];
    u[c] = j[0]; u[3 + c] = j[1]; u[6 + c] = j[2];
  }
}

/* The interval of the table that holds t (kept in w for the next call) and s = t minus
   its knot: a periodic table wraps t into its period; before the first knot the first
   is held, beyond the last the last (or, with extend, its cubic goes on). */
static int crt_law_find(const double *knots, int n_knots, int periodic, int extend,
                        int *interval, double t, double *s)
{
  const double t0 = knots[0], t1 = knots[n_knots - 1];
  int i = *interval;
  if (periodic) {
    const double period = t1 - t0;
    double tt = t0 + fmod(t - t0, period);
    if (tt < t0) tt += period;
    if (tt >= t1) tt = t0;
    t = tt;
  } else if (t < t0) {
    t = t0;
  } else if (t > t1 && !extend) {
    t = t1;
  }
  if (!(i >= 0 && i < n_knots - 1 && knots[i] <= t && t < knots[i + 1])) {
    int lo = 0, hi = n_knots - 1;
    while (hi - lo > 1) {
      const int mid = lo + (hi - lo) / 2;
      if (knots[mid] <= t) lo = mid; else hi = mid;
    }
    i = lo;
    *interval = i;
  }
  *s = t - knots[i];
  return i;
}

static int crt_law_interval(const crt_law *L, crt_law_work *w, double t, double *s)
{
  return crt_law_find(L->knots, L->n_knots, L->periodic, L->extend, &w->interval, t, s);
}

/* one point's table: u = (x, y, z, x', y', z', x'', y'', z'') */
static void crt_law_table(const crt_law *L, crt_law_work *w, double t, double *u)
{
  double s;
  const int i = crt_law_interval(L, w, t, &s);
  int c;
  for (c = 0; c < 3; ++c) {
    const double *k = L->coef + 12L * i + 4 * c;
    u[c] = ((k[0] * s + k[1]) * s + k[2]) * s + k[3];
    u[3 + c] = (3.0 * k[0] * s + 2.0 * k[1]) * s + k[2];
    u[6 + c] = 6.0 * k[0] * s + 2.0 * k[1];
  }
}

/* Several bodies: the program's pass (if any), then each output from its node or its
   column of the table, into u's blocks (point j at 9 j, rotor r at 9 n_points + 3 r). */
static void crt_law_bodies(const crt_law *L, crt_law_work *w, double t, double *u)
{
  const double (*J)[3] = (const double (*)[3])w->jet;
  const int np = L->n_points, n_out = 3 * L->n_points + L->n_rotors;
  double s = 0.0;
  int i = 0, k;
  if (L->n_nodes > 0) crt_law_nodes(L, w, t);
  if (L->n_knots > 0) i = crt_law_interval(L, w, t, &s);
  for (k = 0; k < n_out; ++k) {
    const int src = L->out[k];
    const int at = k < 3 * np ? 9 * (k / 3) + k % 3 : 9 * np + 3 * (k - 3 * np);
    const int step = k < 3 * np ? 3 : 1;     /* from a value to its derivative in u */
    if (src >= 0) {
      const double *j = J[src];
      u[at] = j[0]; u[at + step] = j[1]; u[at + 2 * step] = j[2];
    } else {
      const double *c = L->coef + 4L * L->n_columns * i + 4 * (-1 - src);
      u[at] = ((c[0] * s + c[1]) * s + c[2]) * s + c[3];
      u[at + step] = (3.0 * c[0] * s + 2.0 * c[1]) * s + c[2];
      u[at + 2 * step] = 6.0 * c[0] * s + 2.0 * c[1];
    }
  }
  if (L->ctl_n_knots > 0) {            /* the controller's law over its outputs */
    int c;
    i = crt_law_find(L->ctl_knots, L->ctl_n_knots, 0, 1, &w->ctl_interval, t, &s);
    for (c = 0; c < 3; ++c) {
      const int o = L->ctl_out[c];
      const double *k = L->ctl_coef + 12L * i + 4 * c;
      int at, step;
      if (o < 0) continue;
      at = o < 3 * np ? 9 * (o / 3) + o % 3 : 9 * np + 3 * (o - 3 * np);
      step = o < 3 * np ? 3 : 1;
      u[at] = ((k[0] * s + k[1]) * s + k[2]) * s + k[3];
      u[at + step] = (3.0 * k[0] * s + 2.0 * k[1]) * s + k[2];
      u[at + 2 * step] = 6.0 * k[0] * s + 2.0 * k[1];
    }
  }
}

/* The first knot of a table law after t (beyond a margin of rounding), in run time; +inf
   for a program law or past the end of a table that does not repeat.  Steps end on the
   knots: there the spline's third derivative jumps, and a step across one is rejected
   by the error control (about four times per knot).  This: the law's own table. */
static double crt_law_next_knot_of(const crt_law *L, double t)
{
  const int n = L->n_knots;
  double t0, t1, base = 0.0, tt = t, margin;
  int lo, hi;
  if (L->kind != CRT_LAW_TABLE && !(L->kind == CRT_LAW_BODIES && n > 0)) return HUGE_VAL;
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

/* ... and a controller's law over bodies' outputs (crt_control.h): its knots too */
static double crt_law_next_knot(const crt_law *L, double t)
{
  double next = crt_law_next_knot_of(L, t);
  if (L->kind == CRT_LAW_BODIES && L->ctl_n_knots > 0) {
    const double *k = L->ctl_knots;
    const int n = L->ctl_n_knots;
    const double margin = 1e-12 * (fabs(t) + (k[n - 1] - k[0]));
    int lo = 0, hi = n - 1;
    if (t + margin < k[0]) return crt_min(next, k[0]);
    if (t + margin >= k[n - 1]) return next;
    while (hi - lo > 1) {
      const int mid = lo + (hi - lo) / 2;
      if (k[mid] <= t + margin) lo = mid; else hi = mid;
    }
    next = crt_min(next, k[hi]);
  }
  return next;
}

/* u at t (one point: (x, y, z, x', y', z', x'', y'', z'')); the last value is reused */
static const double *crt_law_eval(const crt_law *L, crt_law_work *w, double t, long *count)
{
  if (w->valid && w->t == t) return w->u;
  ++*count;
  if (L->kind == CRT_LAW_TABLE) crt_law_table(L, w, t, w->u);
  else if (L->kind == CRT_LAW_PROGRAM) crt_law_program(L, w, t, w->u);
  else crt_law_bodies(L, w, t, w->u);
  w->t = t;
  w->valid = 1;
  return w->u;
}

#endif /* CRT_LAW_H */
