/* The trajectory's derived quantities at given states, in one call. */
#include "runtime.h"

/* Outputs at k states Y (rows [q, qd]): qdd, lambda (no stabilization terms), the
 * constraint force A^T lambda, the largest position and velocity residuals, and the
 * energies [T, V, h]. With qdd NULL (lambda and force too) the KKT solves are left
 * out: the residuals and energies alone. */
static int outputs_at(const dl_model *md, dl_data *d, int64_t k, const double *times,
                      const double *Y, double *qdd, double *lambda, double *force,
                      double *position_residual, double *velocity_residual,
                      double *energies) {
  const int64_t n = md->n, m = md->m;
  for (int64_t i = 0; i < k; ++i) {
    const double t = times[i], *q = Y + i * 2 * n, *qd = q + n;
    int status = qdd ? eval_kkt(md, d, t, q, qd) : load_inputs(md, d, t, q, qd);
    if (status == DL_OK && qdd) status = dl_solve(md, d, qdd + i * n, lambda + i * m);
    if (status != DL_OK) return status;
    eval_static(&md->fn[DL_FN_VELOCITY], t, q, d->p, d->vel_values);
    double *vres = d->lambda;  /* A qd + b by row */
    for (int64_t r = 0; r < m; ++r) vres[r] = d->vel_values[md->nA + r];
    if (!qdd) load_pairs(md, d, d->vel_values);  /* A, else loaded by eval_kkt */
    add_A_times(md, d, qd, 1.0, vres);
    if (qdd) {
      double *F = force + i * n;
      const double *lam = lambda + i * m;
      memset(F, 0, (size_t)n * sizeof(double));
      for (int64_t p = 0; p < md->n_pairs; ++p) {  /* F = A^T lam */
        const int64_t b = md->pair_block[p], nb = block_size(md, b), s0 = md->block_start[b];
        const double *a = d->a + md->pair_vec[p];
        for (int64_t j = 0; j < nb; ++j) F[md->slot_coord[s0 + j]] += a[j] * lam[md->pair_row[p]];
      }
    }
    velocity_residual[i] = max_abs(vres, m);
    eval_static(&md->fn[DL_FN_POSITION], t, q, d->p, d->psi);
    position_residual[i] = max_abs(d->psi, md->n_hol);
    eval_state(&md->fn[DL_FN_ENERGY], t, q, qd, d->p, energies + 3 * i);
  }
  return DL_OK;
}

/* The model's inputs at k states Y (rows [q, qd]) as C's evaluations set them (the
 * inputs' callback, then the sliding friction: friction.c), the count slots of the
 * parameter vector from offset, into out (k rows). */
static int inputs_at(const dl_model *md, dl_data *d, int64_t k, const double *times,
                     const double *Y, int64_t offset, int64_t count, double *out) {
  const int64_t n = md->n;
  for (int64_t i = 0; i < k; ++i) {
    const double *q = Y + i * 2 * n;
    const int status = load_inputs(md, d, times[i], q, q + n);
    if (status != DL_OK) return status;
    memcpy(out + i * count, d->p + offset, (size_t)count * sizeof(double));
  }
  return DL_OK;
}

/* The outputs and the inputs are looked at (dl_data's looking): what they evaluate
 * leaves the run's steps as they were. */
int dl_outputs(const dl_model *md, dl_data *d, int64_t k, const double *times, const double *Y,
               double *qdd, double *lambda, double *force, double *position_residual,
               double *velocity_residual, double *energies) {
  d->looking = 1;
  const int status = outputs_at(md, d, k, times, Y, qdd, lambda, force, position_residual,
                                velocity_residual, energies);
  d->looking = 0;
  return status;
}

int dl_inputs(const dl_model *md, dl_data *d, int64_t k, const double *times, const double *Y,
              int64_t offset, int64_t count, double *out) {
  d->looking = 1;
  const int status = inputs_at(md, d, k, times, Y, offset, count, out);
  d->looking = 0;
  return status;
}
