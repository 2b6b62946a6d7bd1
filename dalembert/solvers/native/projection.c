/* Projection of a state onto the constraints (minimum-norm changes), with the Schur
 * solve of kkt.c for M = I: S = J J^T over the holonomic rows (positions) or A A^T
 * (velocities), the dropped dependent rows left out. */
#include "runtime.h"

/* Least-change step dq = -J^T (J J^T)^-1 psi with the factored S = J J^T. */
static void position_step(const dl_model *md, dl_data *d, const double *psi, double *dq) {
  memset(d->lambda, 0, (size_t)md->m * sizeof(double));
  for (int64_t k = 0; k < md->n_hol; ++k) d->lambda[md->holonomic[k]] = -psi[k];
  solve_schur(md, d, d->lambda, d->u);
  for (int64_t s = 0; s < md->n; ++s) dq[md->slot_coord[s]] = d->u[s];
}

/* J J^T at q factored (holonomic rows). */
static int factor_positions(const dl_model *md, dl_data *d, double t, const double *q,
                            const unsigned char *holonomic) {
  eval_static(&md->fn[DL_FN_VELOCITY], t, q, d->p, d->vel_values);
  load_pairs(md, d, d->vel_values);
  return factor_schur(md, d, holonomic) == DL_OK ? DL_OK : DL_PROJECTION;
}

/* Newton on psi(q, t) = 0, as StepProjector.positions: simplified (one factorization)
 * for max_newton iterations, then, if that stalls above the rounding floor (a state
 * far from the constraints, such as a coarse step's interpolant), full Newton for up to
 * max_full more. *moved: the largest change of a coordinate (0 if none was made). */
static int project_positions(const dl_model *md, dl_data *d, double t, double *q,
                             const unsigned char *holonomic, int64_t max_newton,
                             int64_t max_full, double position_tol, double accept_tol,
                             double *moved) {
  const int64_t n = md->n;
  double *psi = d->psi, *trial = d->q_trial, *dq = d->qdd;
  *moved = 0.0;
  eval_static(&md->fn[DL_FN_POSITION], t, q, d->p, psi);
  double residual = max_abs(psi, md->n_hol);
  if (residual <= position_tol) return DL_OK;
  if (factor_positions(md, d, t, q, holonomic) != DL_OK) return DL_PROJECTION;
  for (int64_t it = 0; it < max_newton + max_full; ++it) {
    if (it >= max_newton) {  /* full Newton: psi at q again, J at q */
      eval_static(&md->fn[DL_FN_POSITION], t, q, d->p, psi);
      if (factor_positions(md, d, t, q, holonomic) != DL_OK) return DL_PROJECTION;
    }
    position_step(md, d, psi, dq);
    const double step = max_abs(dq, n);
    *moved = step > *moved ? step : *moved;
    for (int64_t i = 0; i < n; ++i) trial[i] = q[i] + dq[i];
    eval_static(&md->fn[DL_FN_POSITION], t, trial, d->p, psi);
    const double new_residual = max_abs(psi, md->n_hol);
    if (!(new_residual < 0.5 * residual)) {
      if (it >= max_newton) break;  /* rounding floor, or divergence: judged below */
      it = max_newton - 1;          /* the simplified iteration stalled: go full */
      continue;
    }
    memcpy(q, trial, (size_t)n * sizeof(double));
    residual = new_residual;
    if (residual <= position_tol) return DL_OK;
  }
  const double scale = max_abs(q, n) > 1.0 ? max_abs(q, n) : 1.0;
  return residual <= accept_tol * scale ? DL_OK : DL_PROJECTION;
}

/* qd <- qd - A^T (A A^T)^-1 (A qd + b), A and b at q; without refactor, A A^T is the
 * factor left by the positions, at a q that differs at drift level (the change of
 * the result is drift squared). */
static int project_velocities(const dl_model *md, dl_data *d, double t, const double *q, double *qd,
                              int refactor) {
  eval_static(&md->fn[DL_FN_VELOCITY], t, q, d->p, d->vel_values);
  load_pairs(md, d, d->vel_values);
  if (refactor && factor_schur(md, d, NULL) != DL_OK) return DL_PROJECTION;
  const double *b = d->vel_values + md->nA;
  /* lambda = -(A qd + b): the residual, by row */
  for (int64_t r = 0; r < md->m; ++r) d->lambda[r] = -b[r];
  add_A_times(md, d, qd, -1.0, d->lambda);
  solve_schur(md, d, d->lambda, d->u);
  for (int64_t s = 0; s < md->n; ++s) qd[md->slot_coord[s]] += d->u[s];
  return DL_OK;
}

/* y = [q, qd] projected in place: positions (holonomic rows), then velocities. */
int dl_project(const dl_model *md, dl_data *d, double t, double *y,
               const unsigned char *holonomic, int64_t max_newton, int64_t max_full,
               double position_tol, double accept_tol) {
  if (md->m == 0) return DL_OK;
  double moved = 0.0;
  if (md->n_hol) {
    const int status = project_positions(md, d, t, y, holonomic, max_newton, max_full,
                                         position_tol, accept_tol, &moved);
    if (status != DL_OK) return status;
  }
  const double scale = max_abs(y, md->n) > 1.0 ? max_abs(y, md->n) : 1.0;
  const int reuse = md->n_hol == md->m && moved > 0.0 && moved <= 1e-6 * scale;
  return project_velocities(md, d, t, y, y + md->n, !reuse);
}
