/* The friction forces of a contact segment's sliding contacts, computed in C before
 * each evaluation (runtime.h's dl_friction, native/friction.py): the same solve as
 * contacts/friction.py's solve_sliding, on the run's own model, so that a sliding
 * segment's steps do not call Python at every evaluation. */
#include "runtime.h"

/* The work arrays: the current directions (n_tangent), a friction force and its
 * response (n each), a zero row vector, the multipliers without friction and one
 * response's (m each), R and the right-hand side (n_sliding^2 + n_sliding), then the
 * group's (screens.c's work_of): native/friction.py's work size. */
typedef struct { double *direction, *force, *x, *zeros, *lam0, *lam, *R, *N, *group; } friction_work;

DL_INLINE friction_work friction_work_of(const dl_friction *fr, int64_t n, int64_t m) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns];
  friction_work w;
  w.direction = fr->work;
  w.force = w.direction + nt;
  w.x = w.force + n;
  w.zeros = w.x + n;
  w.lam0 = w.zeros + m;
  w.lam = w.lam0 + m;
  w.R = w.lam + m;
  w.N = w.R + ns * ns;
  w.group = w.N + ns;
  return w;
}

/* Tangent row j's value A qd + b from the watched model's velocity values. */
DL_INLINE double tangent_rate(const dl_friction *fr, int64_t j, const double *qd) {
  double s = 0.0;
  for (int64_t e = fr->term_start[j]; e < fr->term_start[j + 1]; ++e) {
    const int64_t col = fr->term_col[e];
    s += fr->vel[fr->term_value[e]] * (col >= 0 ? qd[col] : 1.0);
  }
  return s;
}

/* Contact k's direction: its sliding velocity's s / |s|, or its start direction where
 * s is 0 or does not run along it (past its stop, where a trial stage may look:
 * friction.py's current_direction). */
static void sliding_direction(const dl_friction *fr, int64_t k, const double *qd, double *d) {
  const int64_t j0 = fr->start[k], nj = fr->start[k + 1] - j0;
  double size = 0.0, along = 0.0;
  for (int64_t j = 0; j < nj; ++j) {
    d[j] = tangent_rate(fr, j0 + j, qd);
    size += d[j] * d[j];
    along += d[j] * fr->start_direction[j0 + j];
  }
  size = sqrt(size);
  for (int64_t j = 0; j < nj; ++j)
    d[j] = size == 0.0 || !(along > 0.0) ? fr->start_direction[j0 + j] : d[j] / size;
}

/* The run's multipliers made the minimum-norm ones where it drops rows (in place). */
DL_INLINE int spread(const dl_model *md, const dl_friction *fr, double *work, double *lam) {
  if (!fr->n_group) return 0;
  return group_minimum_norm(md->n, md->m, fr->n_group, fr->n_group_kept, fr->group_row,
                            fr->group_start, fr->group_entry, fr->group_col, fr->run_vel,
                            fr->dependent_rtol, work, lam, lam);
}

/* x = A^-1 b for a small dense A (n x n, row major, overwritten), Gaussian elimination
 * with partial pivoting; 1 where A is singular. */
static int solve_small(double *A, double *b, int64_t n) {
  for (int64_t j = 0; j < n; ++j) {
    int64_t pivot = j;
    for (int64_t i = j + 1; i < n; ++i)
      if (fabs(A[i * n + j]) > fabs(A[pivot * n + j])) pivot = i;
    if (!(A[pivot * n + j] != 0.0)) return 1;
    if (pivot != j) {
      for (int64_t k = 0; k < n; ++k) {
        const double s = A[j * n + k];
        A[j * n + k] = A[pivot * n + k];
        A[pivot * n + k] = s;
      }
      const double s = b[j];
      b[j] = b[pivot];
      b[pivot] = s;
    }
    for (int64_t i = j + 1; i < n; ++i) {
      const double l = A[i * n + j] / A[j * n + j];
      for (int64_t k = j; k < n; ++k) A[i * n + k] -= l * A[j * n + k];
      b[i] -= l * b[j];
    }
  }
  for (int64_t i = n - 1; i >= 0; --i) {
    double s = b[i];
    for (int64_t k = i + 1; k < n; ++k) s -= A[i * n + k] * b[k];
    b[i] = s / A[i * n + i];
  }
  return !all_finite(b, n);
}

int load_friction(const dl_model *md, dl_data *d, double t, const double *q, const double *qd) {
  const dl_friction *fr = d->friction;
  const int64_t n = md->n, m = md->m, ns = fr->n_sliding, nt = fr->start[ns];
  friction_work w = friction_work_of(fr, n, m);
  for (int64_t i = 0; i < fr->n_copy; ++i) fr->p[fr->copy_to[i]] = d->p[fr->copy_from[i]];
  for (int64_t j = 0; j < nt; ++j) d->p[fr->slot[j]] = 0.0;
  eval_static(&fr->velocity, t, q, fr->p, fr->vel);
  if (fr->n_group) eval_static(&fr->run_velocity, t, q, d->p, fr->run_vel);
  for (int64_t k = 0; k < ns; ++k) sliding_direction(fr, k, qd, w.direction + fr->start[k]);
  /* the solve without friction, which holds the factors for the responses */
  eval_state(&md->fn[DL_FN_KKT], t, q, qd, d->p, d->values);
  if (!md->kkt_in_layout) load_kkt(md, d);
  int status = dl_solve(md, d, w.x, w.lam0);
  if (status != DL_OK) return status;
  if (spread(md, fr, w.group, w.lam0)) return DL_RANK_CHANGED;
  /* the response to each contact's friction per unit normal force, -mu A_t^T d */
  for (int64_t k = 0; k < ns; ++k) {
    memset(w.force, 0, (size_t)n * sizeof(double));
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j)
      for (int64_t e = fr->term_start[j]; e < fr->term_start[j + 1]; ++e)
        if (fr->term_col[e] >= 0)
          w.force[fr->term_col[e]] -= fr->mu[k] * w.direction[j] * fr->vel[fr->term_value[e]];
    kkt_solve_one(md, d, w.force, w.zeros, w.x, w.lam);
    if (spread(md, fr, w.group, w.lam)) return DL_RANK_CHANGED;
    for (int64_t i = 0; i < ns; ++i) w.R[i * ns + k] = (i == k) - w.lam[fr->normal[i]];
  }
  /* N = lambda0_n + R N */
  for (int64_t i = 0; i < ns; ++i) w.N[i] = w.lam0[fr->normal[i]];
  if (solve_small(w.R, w.N, ns)) return DL_SINGULAR_CONSTRAINTS;
  for (int64_t k = 0; k < ns; ++k)
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j)
      d->p[fr->slot[j]] = -fr->mu[k] * w.N[k] * w.direction[j];
  return DL_OK;
}
