/* Explicit Runge-Kutta steps as scipy.integrate's RungeKutta takes them, and whole
 * stretches of the simulation loop: step, projection, outputs, restart. */
#include "runtime.h"

/* out = sum_k w[k * stride] K[k] over k < count (rows of K contiguous, zero weights
 * skipped, count <= DL_MAX_ROWS). Each out[i] is summed in a register in the order of
 * k: one store per entry instead of one load and store per weight. */
enum { DL_MAX_ROWS = 32 };
static void weigh(const double *K, const double *w, int64_t stride, int64_t count,
                  int64_t n_state, double *out) {
  const double *rows[DL_MAX_ROWS];
  double weights[DL_MAX_ROWS];
  int64_t used = 0;
  for (int64_t k = 0; k < count; ++k)
    if (w[k * stride] != 0.0) {
      rows[used] = K + k * n_state;
      weights[used++] = w[k * stride];
    }
  int64_t i = 0;
  for (; i + 4 <= n_state; i += 4) {  /* four sums at once: independent chains */
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    for (int64_t k = 0; k < used; ++k) {
      const double wk = weights[k], *r = rows[k] + i;
      s0 += wk * r[0];
      s1 += wk * r[1];
      s2 += wk * r[2];
      s3 += wk * r[3];
    }
    out[i] = s0;
    out[i + 1] = s1;
    out[i + 2] = s2;
    out[i + 3] = s3;
  }
  for (; i < n_state; ++i) {
    double s = 0.0;
    for (int64_t k = 0; k < used; ++k) s += weights[k] * rows[k][i];
    out[i] = s;
  }
}

/* scipy's error norms; work (2 n_state) holds the estimates. */
static double error_norm(const dl_tableau *tb, const double *K, int64_t n_state, double h,
                         const double *scale, double *work) {
  const int64_t s1 = tb->n_stages + 1;
  double *x5 = work, *x3 = work + n_state;
  weigh(K, tb->E, 1, s1, n_state, x5);
  if (tb->E3) weigh(K, tb->E3, 1, s1, n_state, x3);
  else memset(x3, 0, (size_t)n_state * sizeof(double));
  double e5 = 0.0, e3 = 0.0;
  for (int64_t i = 0; i < n_state; ++i) {
    const double a = x5[i] / scale[i], b = x3[i] / scale[i];
    e5 += a * a;
    e3 += b * b;
  }
  if (!tb->E3) return fabs(h) * sqrt(e5 / n_state);
  if (e5 == 0.0 && e3 == 0.0) return 0.0;
  return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * n_state);
}

/* out = y + h sum_k w[k] K[k] over k < count. */
static void combine(const double *y, double h, const double *K, const double *w, int64_t count,
                    int64_t n_state, double *out) {
  weigh(K, w, 1, count, n_state, out);
  for (int64_t i = 0; i < n_state; ++i) out[i] = y[i] + h * out[i];
}

/* Stages j0 <= j < j1: K[j] = f(t + C[j - row0] h, y + h sum_k A[j - row0][k] K[k]);
 * A has rows of length lda and starts at stage row0. */
int dl_stages(const dl_model *md, dl_data *d, const double *A, int64_t lda, const double *C,
              int64_t row0, int64_t j0, int64_t j1, double t, double h, const double *y,
              double *K, double *stage, int64_t *nfev) {
  const int64_t n_state = 2 * md->n;
  for (int64_t j = j0; j < j1; ++j) {
    combine(y, h, K, A + (j - row0) * lda, j, n_state, stage);
    ++*nfev;
    const int status = dl_rhs(md, d, t + C[j - row0] * h, stage, K + j * n_state, NULL);
    if (status != DL_OK) return status;
  }
  return DL_OK;
}

/* One Runge-Kutta step from (st->t, y, f = K[0] on entry): y_new, f_new = K[s]. */
static int rk_attempt(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st,
                      double h, const double *y, double *K, double *y_new,
                      double *stage) {
  const int64_t n_state = 2 * md->n, s = tb->n_stages;
  const int status = dl_stages(md, d, tb->A, s, tb->C, 0, 1, s, st->t, h, y, K, stage, &st->nfev);
  if (status != DL_OK) return status;
  combine(y, h, K, tb->B, s, n_state, y_new);
  st->nfev++;
  const int rhs = dl_rhs(md, d, st->t + h, y_new, K + s * n_state, NULL);
  /* the stiffness estimate (steppers/stiffness.py): stage holds the last stage's argument */
  double num = 0.0, den = 0.0;
  for (int64_t i = 0; i < n_state; ++i) {
    const double df = K[s * n_state + i] - K[(s - 1) * n_state + i], dy = y_new[i] - stage[i];
    num += df * df;
    den += dy * dy;
  }
  st->h_lambda = den > 0.0 ? fabs(h) * sqrt(num / den) : NAN;
  return rhs;
}

/* Steps from st->t until one is accepted (steppers/runge_kutta.py's controlled_step, under
 * the controller whose values st holds; scipy's own steps with beta = 0). K[0] must hold
 * f(t, y) on entry; on return y_new, K[s] = f(t_new, y_new) and st is advanced.
 * DL_NOT_FINITE if t, the step size (NaN), y or f(t, y) is not: a NaN step never falls
 * below min_step and would be retried forever. Otherwise the retries end: each
 * rejection shrinks the step by the safety factor at least (min_factor where the error is NaN, as a
 * stage that is not finite makes it) until it is accepted or below min_step. */
int dl_rk_step(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st,
               const double *y, double *K, double *y_new, double *stage) {
  const int64_t n_state = 2 * md->n;
  const double t = st->t;
  if (!isfinite(t) || isnan(st->h_abs) || !all_finite(y, n_state) || !all_finite(K, n_state))
    return DL_NOT_FINITE;
  const double min_step = 10.0 * fabs(nextafter(t, st->direction * INFINITY) - t);
  double h_abs = st->h_abs;
  if (h_abs > st->max_step) h_abs = st->max_step;
  else if (h_abs < min_step) h_abs = min_step;
  int rejected = 0, rank_missed = 0;
  for (;;) {
    if (h_abs < min_step) return rank_missed ? DL_RANK_CHANGED : DL_STEP_TOO_SMALL;
    double t_new = t + h_abs * st->direction;
    if (st->direction * (t_new - st->t_bound) > 0) t_new = st->t_bound;
    const double h = t_new - t;
    h_abs = fabs(h);
    const int status = rk_attempt(md, d, tb, st, h, y, K, y_new, stage);
    if (status == DL_RANK_CHANGED) {
      /* a stage or the end where the dropped rows no longer follow from the kept ones:
       * off the motion (a step too long) or a real change of rank, which a step short
       * enough to end before it tells apart (it is taken; the next one meets it) */
      h_abs *= st->min_factor;
      rejected = rank_missed = 1;
      continue;
    }
    if (status != DL_OK) return status;
    for (int64_t i = 0; i < n_state; ++i) {
      const double big = fabs(y[i]) > fabs(y_new[i]) ? fabs(y[i]) : fabs(y_new[i]);
      stage[i] = st->atol[i] + big * st->rtol;
    }
    const double err = error_norm(tb, K, n_state, h, stage, d->error_work);
    if (err < 1.0) {
      double factor = err == 0.0 ? st->max_factor
                                 : st->safety * pow(err, -st->alpha) * pow(st->err_old, st->beta);
      if (factor > st->max_factor) factor = st->max_factor;
      st->err_old = err > st->error_floor ? err : st->error_floor;
      if (rejected && factor > 1.0) factor = 1.0;
      st->h_abs = h_abs * factor;
      st->h_previous = h;
      st->t = t_new;
      return DL_OK;
    }
    const double shrink = st->safety * pow(err, -st->alpha);
    h_abs *= shrink > st->min_factor ? shrink : st->min_factor;
    rejected = 1;
  }
}

/* ---- whole stretches of steps: step, projection, outputs, restart --------------- */
/* The interpolant of the step t_old -> t_old + h from the solver state before the
 * restart (y_old, the unprojected y_new, the stages K), made as scipy makes it:
 * rows = (K^T P)^T for RkDenseOutput; for DOP853 the extra stages go into K, then
 * rows = F: [dy, h f_old - dy, 2 dy - h (f_new + f_old), h D K]. */
static int make_interpolant(const dl_model *md, dl_data *d, const dl_tableau *tb,
                            dl_stepper *st, double t_old, double h, const double *y_old,
                            const double *y_new, double *K, double *rows, double *stage) {
  const int64_t n_state = 2 * md->n, s1 = tb->n_stages + 1;
  if (!tb->n_extra) {
    for (int64_t j = 0; j < tb->n_P; ++j)
      weigh(K, tb->P + j, tb->n_P, s1, n_state, rows + j * n_state);
    return DL_OK;
  }
  const int64_t width = s1 + tb->n_extra;
  const int status = dl_stages(md, d, tb->A_extra, width, tb->C_extra, s1, s1, width, t_old, h,
                               y_old, K, stage, &st->nfev);
  if (status != DL_OK) return status;
  const double *f_old = K, *f_new = K + tb->n_stages * n_state;
  double *F0 = rows, *F1 = rows + n_state, *F2 = rows + 2 * n_state;
  for (int64_t i = 0; i < n_state; ++i) {
    const double dy = y_new[i] - y_old[i];
    F0[i] = dy;
    F1[i] = h * f_old[i] - dy;
    F2[i] = 2 * dy - h * (f_new[i] + f_old[i]);
  }
  for (int64_t j = 0; j < tb->n_D; ++j) {
    double *Fj = rows + (3 + j) * n_state;
    weigh(K, tb->D + j * width, 1, width, n_state, Fj);
    for (int64_t i = 0; i < n_state; ++i) Fj[i] *= h;
  }
  return DL_OK;
}

/* The interpolant at t, with the operations of scipy's RkDenseOutput (y_old + h Q p,
 * p = [x, x^2, ...]) or Dop853DenseOutput (Horner-like in x and 1 - x). */
static void interpolate(const dl_tableau *tb, int64_t n_state, double t_old, double h,
                        const double *y_old, const double *rows, double t, double *y) {
  const double x = (t - t_old) / h;
  memset(y, 0, (size_t)n_state * sizeof(double));
  if (!tb->n_extra) {
    double p = x;
    for (int64_t j = 0; j < tb->n_P; ++j, p *= x)
      for (int64_t i = 0; i < n_state; ++i) y[i] += rows[j * n_state + i] * p;
    for (int64_t i = 0; i < n_state; ++i) y[i] = h * y[i] + y_old[i];
    return;
  }
  const int64_t n_F = tb->n_D + 3;
  for (int64_t k = 0; k < n_F; ++k) {
    const double *f = rows + (n_F - 1 - k) * n_state, w = k % 2 == 0 ? x : 1 - x;
    for (int64_t i = 0; i < n_state; ++i) y[i] = (y[i] + f[i]) * w;
  }
  for (int64_t i = 0; i < n_state; ++i) y[i] += y_old[i];
}

/* One step from (st->t, y, K[0] = f(t, y)), finished as the Python loop finishes it:
 * the end projected into y_end (DL_EVENT if a screen flags it), the outputs in (t_old, t_new] written after row
 * run->n_out (interpolated and projected; the one at t_new is the projected end). On
 * DL_OK the outputs are counted (n_out, next_eval) and the caller restarts from y_end;
 * on any other status run is as before and the caller restores st. */
static int finish_step(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st,
                       dl_run *run, const double *y, double *K, double *stage) {
  const int64_t n_state = 2 * md->n;
  const double t_old = st->t;
  int status = dl_rk_step(md, d, tb, st, y, K, run->y_new, stage);
  if (status != DL_OK) return status;
  const double t_new = st->t;
  const int every_step = run->n_eval < 0;
  int64_t hi, count;
  if ((status = end_of_step(md, d, run, t_new, st->direction, &hi, &count)) != DL_OK)
    return status;
  const double conditioning = d->conditioning;  /* the projection's (a screen may solve) */
  if (run->screens && screened(md, d, run->screens, t_new, run->y_end, NULL)) return DL_EVENT;
  int made = 0;
  for (int64_t k = 0; k < count; ++k) {
    const double s = every_step ? t_new : run->t_eval[run->next_eval + k];
    double *row = run->y_out + (run->n_out + k) * n_state;
    run->t_out[run->n_out + k] = s;
    if (s == t_new) {
      memcpy(row, run->y_end, (size_t)n_state * sizeof(double));
      continue;
    }
    if (!made && (status = make_interpolant(md, d, tb, st, t_old, t_new - t_old, y, run->y_new, K,
                                            run->rows, stage)) != DL_OK)
      return status;
    made = 1;
    interpolate(tb, n_state, t_old, t_new - t_old, y, run->rows, s, row);
    if ((status = run_project(md, d, run, s, row)) != DL_OK) return status;
  }
  run->next_eval = hi;
  run->n_out += count;
  return conditioning < run->near2 ? DL_NEAR_SINGULAR : DL_OK;
}

/* The stiffness detector's memory after an accepted step (steppers/stiffness.py's
 * StiffnessDetector.note, its constants in st); 1 when it says stiff. */
static int note_stiffness(dl_stepper *st) {
  if (st->h_lambda > st->stiff_limit) {
    ++st->stiff_count;
    st->calm_count = 0;
  } else if (st->h_lambda <= st->stiff_limit && ++st->calm_count >= st->calm_after) {
    st->stiff_count = st->calm_count = 0;
  }
  return st->stiff_count >= st->stiff_after;
}

/* Steps from (st->t, y, K[0] = f(t, y)) as the Python loop takes them (finish_step),
 * until t_bound, the step or time budget, or a full output buffer. On return y,
 * K[0] and st hold the state after the last finished step; a non-OK status means
 * the next step could not be finished here (too small, a singular system, a failed
 * projection, more outputs than the buffer holds): the caller takes that step
 * itself, from this state, and st->nfev does not count the dropped attempt (a step that
 * would start from values that are not finite is one: DL_NOT_FINITE, see dl_rk_step).
 * Every loop inside a step is bounded, so the call returns within a step of the time
 * budget and Ctrl-C is served. With st->stiff_limit > 0 the call also ends, DL_STIFF,
 * after the step that makes the stiffness detector say stiff (the caller may switch to
 * an implicit method). */
int dl_rk_run(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st, dl_run *run,
              double *y, double *K, double *stage) {
  const int64_t n_state = 2 * md->n;
  const double start = wall_seconds();
  run->n_steps = run->n_out = 0;
  if (!isfinite(st->t)) return DL_NOT_FINITE;  /* the loop below would not start */
  while (st->direction * (st->t - st->t_bound) < 0 && run->n_steps < run->max_steps) {
    if (run->n_steps && wall_seconds() - start > run->max_seconds) break;
    const dl_stepper before = *st;
    keep_onset_memory(d, 0);
    const int status = finish_step(md, d, tb, st, run, y, K, stage);
    if (status != DL_OK && status != DL_NEAR_SINGULAR) {
      *st = before;
      keep_onset_memory(d, 1);
      /* a full buffer after some steps just ends this call */
      return status == DL_OUTPUTS && run->n_steps ? DL_OK : status;
    }
    run->t_old = before.t;
    ++run->n_steps;
    memcpy(y, run->y_end, (size_t)n_state * sizeof(double));
    /* f at the restart, as _restart_from makes it (integrate.py says why): [qd, qdd]
     * with the projected qd and the last stage's qdd, at the end before the projection */
    memcpy(K, y + md->n, (size_t)md->n * sizeof(double));
    memcpy(K + md->n, K + tb->n_stages * n_state + md->n, (size_t)md->n * sizeof(double));
    if (status == DL_NEAR_SINGULAR) return status;  /* the caller measures and decides */
    if (st->stiff_limit > 0.0 && note_stiffness(st)) return DL_STIFF;
  }
  return DL_OK;
}
