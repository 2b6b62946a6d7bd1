/* The KKT solve (range-space / Schur complement, linear in the mechanism):
 *   M qdd = f + A^T lam,  A qdd = c.
 * M is block diagonal (one block per body). Rows lying inside one block (a
 * quaternion's unit norm) are folded into it, Mt = M_b + w a a^T, f_b += w a c_r:
 * true for every solution, and it makes a quaternion body's singular block
 * positive definite. Then, with Y = Mt^-1 A^T and u = Mt^-1 f,
 *   S lam = c - A u,  S = A Mt^-1 A^T (banded for chains and trees),  qdd = u + Y lam,
 * computed with the blocks' Cholesky factors Mt = L L^T as S = Z^T Z, Z = L^-1 A^T.
 * With dependent rows, the kept ones alone are solved (the dropped ones have no place
 * in the blocks or the band) and the dropped ones are checked (check_dropped).
 * One factorization (kkt_factor) serves the right-hand side (dl_solve, every row, the
 * right-hand side carried along) and the general entry (dl_kkt_factor: any active
 * rows, many right-hand sides); the projections solve J J^T (M = I) with its steps
 * (factor_schur, solve_schur).
 */
#include "runtime.h"

/* Blocks up to this size keep a vector of theirs in registers (BY_SIZE's sizes). */
enum { DL_SMALL_BLOCK = 4 };

void eval_state(const dl_function *F, double t, const double *q, const double *qd,
                const double *p, double *out) {
  if (F->size == 0) return;
  if (F->K) {
    memset(out, 0, (size_t)F->size * sizeof(double));
    ((scatter_state)F->fn)(F->K, F->index, F->target, &t, q, qd, p, out);
  } else {
    ((flat_state)F->fn)(&t, q, qd, p, out);
  }
}

void eval_static(const dl_function *F, double t, const double *q, const double *p,
                 double *out) {
  if (F->size == 0) return;
  if (F->K) {
    memset(out, 0, (size_t)F->size * sizeof(double));
    ((scatter_static)F->fn)(F->K, F->index, F->target, &t, q, p, out);
  } else {
    ((flat_static)F->fn)(&t, q, p, out);
  }
}

/* The widest band whose LDL^T rows keep their products in registers (BY_WIDTH's
 * widths); wider rows read them back from memory, where they were stored an instant
 * before, so each waits for the store as well as for the arithmetic. */
enum { DL_BAND_WINDOW = 9 };

/* Band LDL^T, row by row: S[i * (kd + 1) + (i - j)] holds S_ij for i - kd <= j <= i;
 * on return the unit lower L below the diagonal and 1 / D_i on it. No square roots:
 * a pivot waits only for the division of the one before (in L L^T also for its root),
 * and the rows follow each other in one chain. The row's products u_j = L_ij D_j
 * first take the places of S_ij, then turn into L_ij; row i's band starts at column
 * k0, and so does every sum (the rows j >= k0 before it reach back to k0 at least). */
DL_INLINE int ldl_row(double *restrict S, int64_t i, int64_t k0, int64_t w) {
  double *Si = S + i * w + i;  /* Si[-j] = S_ij */
  for (int64_t j = k0; j < i; ++j) {
    const double *Sj = S + j * w + j;
    double u = Si[-j];
    for (int64_t k = k0; k < j; ++k) u -= Si[-k] * Sj[-k];
    Si[-j] = u;
  }
  double d = Si[-i];
  const double scale = fabs(d);
  for (int64_t j = k0; j < i; ++j) {
    const double l = Si[-j] * S[j * w];
    d -= Si[-j] * l;
    Si[-j] = l;
  }
  if (!(d > 1e-14 * scale) || !(d > 0.0)) return DL_SINGULAR_CONSTRAINTS;
  Si[-i] = 1.0 / d;
  return DL_OK;
}

/* A full-width row of ldl_row (i >= kd), the products u kept in registers
 * (DL_BAND_WINDOW) until they turn into L_ij; same operations in the same order. */
DL_INLINE int ldl_row_window(double *restrict S, int64_t i, int64_t kd) {
  const int64_t w = kd + 1;
  double *Si = S + i * w;  /* Si[d] = S_{i, i - d} */
  double u[DL_BAND_WINDOW];
  for (int64_t a = 0; a < kd; ++a) {  /* column j = i - kd + a */
    const double *Sj = S + (i - kd + a) * w;  /* Sj[e] = L_{j, j - e} */
    double v = Si[kd - a];
    for (int64_t b = 0; b < a; ++b) v -= u[b] * Sj[a - b];
    u[a] = v;
  }
  double d = Si[0];
  const double scale = fabs(d);
  for (int64_t a = 0; a < kd; ++a) {
    const double l = u[a] * S[(i - kd + a) * w];
    d -= u[a] * l;
    Si[kd - a] = l;
  }
  if (!(d > 1e-14 * scale) || !(d > 0.0)) return DL_SINGULAR_CONSTRAINTS;
  Si[0] = 1.0 / d;
  return DL_OK;
}

/* The first kd rows (shorter), then the others, whose band is kd wide: with kd a
 * constant (BY_WIDTH) their loops unroll into straight code. */
DL_INLINE int band_ldl_by_width(double *restrict S, int64_t m, int64_t kd) {
  const int64_t w = kd + 1, head = kd < m ? kd : m;
  for (int64_t i = 0; i < head; ++i)
    if (ldl_row(S, i, 0, w) != DL_OK) return DL_SINGULAR_CONSTRAINTS;
  if (kd <= DL_BAND_WINDOW) {
    for (int64_t i = head; i < m; ++i)
      if (ldl_row_window(S, i, kd) != DL_OK) return DL_SINGULAR_CONSTRAINTS;
    return DL_OK;
  }
  for (int64_t i = head; i < m; ++i)
    if (ldl_row(S, i, i - kd, w) != DL_OK) return DL_SINGULAR_CONSTRAINTS;
  return DL_OK;
}

static int band_ldl(double *S, int64_t m, int64_t kd) {
  return BY_WIDTH(kd, band_ldl_by_width, S, m);
}

/* x_i -= sum over k0 <= k < i of L_ik x_k, x_{i-1} = prev: the x just found, the one
 * the row waits for, carried in a register instead of read back from x, where it was
 * stored an instant before; the new x_i is returned. */
DL_INLINE double forward_row(const double *restrict S, int64_t i, int64_t k0, int64_t w,
                             double *restrict x, double prev) {
  const double *Si = S + i * w + i;
  double s = x[i];
  for (int64_t k = k0; k < i - 1; ++k) s -= Si[-k] * x[k];
  if (k0 < i) s -= Si[-(i - 1)] * prev;
  return x[i] = s;
}

/* x_i -= sum over i < k <= k1 of L_ki x_k, from k1 down, x_{i+1} = prev (as in
 * forward_row: each sum ends with the x just found, so a row waits for the one before
 * by one multiply-add, not kd); the new x_i is returned. */
DL_INLINE double backward_row(const double *restrict S, int64_t i, int64_t k1, int64_t w,
                              double *restrict x, double prev) {
  double s = x[i];
  for (int64_t k = k1; k > i + 1; --k) s -= S[k * w + (k - i)] * x[k];
  if (k1 > i) s -= S[(i + 1) * w + 1] * prev;
  return x[i] = s;
}

/* x <- S^-1 x from band_ldl's factors (rows whose band is kd wide apart, as there). */
DL_INLINE void band_solve_by_width(const double *restrict S, int64_t m, double *restrict x,
                                   int64_t kd) {
  const int64_t w = kd + 1, head = kd < m ? kd : m;
  double prev = 0.0;
  for (int64_t i = 0; i < head; ++i) prev = forward_row(S, i, 0, w, x, prev);
  for (int64_t i = head; i < m; ++i) prev = forward_row(S, i, i - kd, w, x, prev);
  for (int64_t i = 0; i < m; ++i) x[i] *= S[i * w];
  prev = 0.0;
  for (int64_t i = m - 1; i >= m - head; --i) prev = backward_row(S, i, m - 1, w, x, prev);
  for (int64_t i = m - head - 1; i >= 0; --i) prev = backward_row(S, i, i + kd, w, x, prev);
}

static void band_solve(const double *S, int64_t m, int64_t kd, double *x) {
  BY_WIDTH(kd, band_solve_by_width, S, m, x);
}

/* Scatter the values of A (pattern order) into the pair vectors. Nothing else writes
 * them, so the slots no value lands in keep the zeros they were allocated with. */
void load_pairs(const dl_model *md, dl_data *d, const double *Av) {
  for (int64_t e = 0; e < md->nA; ++e) d->a[md->A_at[e]] = Av[e];
}

/* out[r] += w (A x)_r over every row (the dropped ones too), with A in the pair vectors
 * and x by global coordinate. */
void add_A_times(const dl_model *md, const dl_data *d, const double *x, double w,
                 double *out) {
  for (int64_t p = 0; p < md->n_pairs + md->n_dropped_pairs; ++p) {
    const int64_t b = md->pair_block[p], nb = block_size(md, b), s0 = md->block_start[b];
    const double *a = d->a + md->pair_vec[p];
    double s = 0.0;
    for (int64_t i = 0; i < nb; ++i) s += a[i] * x[md->slot_coord[s0 + i]];
    out[md->pair_row[p]] += w * s;
  }
}

/* Whether row r (pair p's) takes part; active NULL: every row, the loop's case, where
 * no mask is read (the callers are inlined with the NULL). */
DL_INLINE int row_active(const unsigned char *active, int64_t r) {
  return !active || active[r];
}

DL_INLINE int is_active(const unsigned char *active, const dl_model *md, int64_t p) {
  return row_active(active, md->pair_row[p]);
}

/* The weight of a folded row a: w |a|^2 is the block's mean diagonal (1 without one). */
DL_INLINE double fold_weight(double trace, double norm2, int64_t nb) {
  return trace > 0.0 ? trace / (nb * norm2) : 1.0 / norm2;
}

/* Block b of M (scattered) with its active internal rows folded in, factored (Mt =
 * L L^T). Each row's weight goes to fold (0: not folded), for the right-hand sides
 * solved later (solve_block_down); with c, u_b += w c_r a_r at once (dl_solve's
 * pass). */
DL_INLINE int fold_factor_block(const dl_model *md, dl_data *d, int64_t b,
                                const unsigned char *active, const double *c, int64_t nb) {
  double *restrict B = d->blocks + md->block_mat[b];
  double *restrict u = d->u + md->block_start[b];
  double trace = 0.0;
  for (int64_t i = 0; i < nb; ++i) trace += B[i * nb + i];
  for (int64_t p = md->block_pairs[b]; p < md->block_external[b]; ++p) {
    const double *restrict a = d->a + md->pair_vec[p];
    const double norm2 = dot(a, a, nb);
    d->factor.fold[p] = 0.0;
    if (!is_active(active, md, p) || norm2 == 0.0) continue;
    const double w = fold_weight(trace, norm2, nb);
    d->factor.fold[p] = w;
    const double wc = c ? w * c[md->pair_row[p]] : 0.0;
    for (int64_t i = 0; i < nb; ++i) {
      if (c) u[i] += wc * a[i];
      for (int64_t j = 0; j <= i; ++j) B[i * nb + j] += w * a[i] * a[j];
    }
  }
  return cholesky(B, nb);
}

/* z_p = L^-1 a_p for block b's pairs, and with f (u by slot) u_b = L^-1 f_b. */
DL_INLINE void block_forward(const dl_model *md, dl_data *d, int64_t b, int with_rhs,
                             int64_t nb) {
  const double *restrict B = d->blocks + md->block_mat[b];
  if (with_rhs) forward(B, nb, d->u + md->block_start[b]);
  const int64_t p0 = md->block_pairs[b], p1 = md->block_pairs[b + 1];
  const double *restrict a = d->a + md->pair_vec[p0];
  double *restrict z = d->y + md->pair_vec[p0];
  for (int64_t k = 0; k < p1 - p0; ++k) forward_into(B, nb, a + k * nb, z + k * nb);
}

/* Block b's active internal rows (its first pairs) eliminated from S, one Gaussian
 * pivot after the other: each later active pair of the block loses its part along
 * the pivot (z_p -= alpha z_i, alpha = z_i.z_p / z_i.z_i), so that Z^T Z over the
 * block's external pairs is S with the pivots eliminated. elim keeps, per pivot,
 * 1 / z_i.z_i and the alphas (for eliminate_rhs and recover_internal). */
DL_INLINE int eliminate_internal(const dl_model *md, dl_data *d, int64_t b, double *z,
                                 const unsigned char *active, int64_t nb) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  const int several = pe - p0 > 1;
  if (several)  /* the pivots' scales, before any elimination (one pivot: its own) */
    for (int64_t i = p0; i < pe; ++i)
      if (is_active(active, md, i))
        d->elim[md->elim_at[i]] = dot(z + md->pair_vec[i], z + md->pair_vec[i], nb);
  for (int64_t i = p0; i < pe; ++i) {
    if (!is_active(active, md, i)) continue;
    const double *restrict zi = z + md->pair_vec[i];
    double *restrict e = d->elim + md->elim_at[i];
    const double s = dot(zi, zi, nb);
    if (!(s > 1e-14 * (several ? e[0] : s))) return DL_SINGULAR_CONSTRAINTS;  /* dependent */
    e[0] = 1.0 / s;
    for (int64_t p = i + 1; p < p1; ++p) {
      if (!is_active(active, md, p)) continue;
      double *restrict zp = z + md->pair_vec[p];
      const double alpha = dot(zi, zp, nb) * e[0];
      e[p - i] = alpha;
      for (int64_t k = 0; k < nb; ++k) zp[k] -= alpha * zi[k];
    }
  }
  return DL_OK;
}

/* The right-hand side through block b's pivots (as eliminate_internal left them): per
 * pivot i, c_p -= alpha c_i for the later rows and u_b += beta z_i, beta = (c_i - z_i.u_b)
 * / z_i.z_i, kept in c_i for recover_internal. Then S lam = c - Z^T u over the external
 * rows, and u + Z lam over the external pairs is the block's solution (u by slot). */
DL_INLINE void eliminate_rhs(const dl_model *md, const dl_data *d, int64_t b, const double *z,
                             const unsigned char *active, double *c, double *u, int64_t nb) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  double *restrict ub = u + md->block_start[b];
  for (int64_t i = p0; i < pe; ++i) {
    if (!is_active(active, md, i)) continue;
    const double *restrict zi = z + md->pair_vec[i], *restrict e = d->elim + md->elim_at[i];
    const double ci = c[md->pair_row[i]];
    for (int64_t p = i + 1; p < p1; ++p)
      if (is_active(active, md, p)) c[md->pair_row[p]] -= e[p - i] * ci;
    const double beta = (ci - dot(zi, ub, nb)) * e[0];
    for (int64_t k = 0; k < nb; ++k) ub[k] += beta * zi[k];
    c[md->pair_row[i]] = beta;
  }
}

/* The multipliers of block b's active internal rows from the others', last pivot
 * first: lam_i = beta_i - sum over the later rows of alpha lam_p (the projections do
 * not need these multipliers). */
static void recover_internal(const dl_model *md, const dl_data *d, const unsigned char *active,
                             int64_t b, double *lam) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  for (int64_t i = pe - 1; i >= p0; --i) {
    if (!is_active(active, md, i)) continue;
    const double *e = d->elim + md->elim_at[i];
    double l = lam[md->pair_row[i]];
    for (int64_t p = i + 1; p < p1; ++p)
      if (is_active(active, md, p)) l -= e[p - i] * lam[md->pair_row[p]];
    lam[md->pair_row[i]] = l;
  }
}

/* S += Z_b^T Z_b over the block's external pairs and the active rows; block b's pair
 * vectors z are contiguous, nb values each. */
DL_INLINE void gram_block(const dl_model *md, int64_t b, const double *z,
                          const unsigned char *active, double *S, int64_t nb) {
  const int64_t p0 = md->block_external[b], pb = md->block_pairs[b + 1] - p0;
  const double *restrict zb = z + md->pair_vec[p0];
  const int64_t *restrict target = md->gram_target + md->gram_start[b];
  if (active) {
    for (int64_t i = 0, k = 0; i < pb; ++i)
      for (int64_t j = 0; j <= i; ++j, ++k)
        if (active[md->pair_row[p0 + i]] && active[md->pair_row[p0 + j]])
          S[target[k]] += dot(zb + i * nb, zb + j * nb, nb);
  } else {
    for (int64_t i = 0, k = 0; i < pb; ++i)
      for (int64_t j = 0; j <= i; ++j, ++k) S[target[k]] += dot(zb + i * nb, zb + j * nb, nb);
  }
}

/* rhs[r] -= z_p . x_b over block b's external pairs (x by slot). */
DL_INLINE void block_residual(const dl_model *md, int64_t b, const double *z, const double *x,
                              double *rhs, int64_t nb) {
  const double *restrict xb = x + md->block_start[b];
  if (nb <= DL_SMALL_BLOCK) {  /* x_b in registers: the stores to rhs could alias it */
    double xs[DL_SMALL_BLOCK];
    for (int64_t i = 0; i < nb; ++i) xs[i] = xb[i];
    for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p)
      rhs[md->pair_row[p]] -= dot(z + md->pair_vec[p], xs, nb);
    return;
  }
  for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p)
    rhs[md->pair_row[p]] -= dot(z + md->pair_vec[p], xb, nb);
}

/* x_b += Z_b lam over block b's external pairs (x by slot, lam by row). */
DL_INLINE void block_update(const dl_model *md, int64_t b, const double *z, const double *lam,
                            double *x, int64_t nb) {
  double *restrict xb = x + md->block_start[b];
  if (nb <= DL_SMALL_BLOCK) {  /* the sums in registers, x_b stored once */
    double s[DL_SMALL_BLOCK] = {0.0};
    for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p) {
      const double l = lam[md->pair_row[p]];
      const double *restrict zp = z + md->pair_vec[p];
      for (int64_t i = 0; i < nb; ++i) s[i] += zp[i] * l;
    }
    for (int64_t i = 0; i < nb; ++i) xb[i] += s[i];
    return;
  }
  for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p) {
    const double l = lam[md->pair_row[p]];
    const double *restrict zp = z + md->pair_vec[p];
    for (int64_t i = 0; i < nb; ++i) xb[i] += zp[i] * l;
  }
}

/* x_b <- L_b^-T x_b (x by slot). */
DL_INLINE void block_backward(const dl_model *md, const dl_data *d, int64_t b, double *x,
                              int64_t nb) {
  backward(d->blocks + md->block_mat[b], nb, x + md->block_start[b]);
}

static void clear_band(const dl_model *md, dl_data *d) {
  memset(d->S, 0, (size_t)(md->m_band * (md->kd + 1)) * sizeof(double));
}

/* The rows the gram products leave out get a unit diagonal; S factored. */
static int factor_band(const dl_model *md, dl_data *d, const unsigned char *active) {
  const int64_t w = md->kd + 1;
  if (active)
    for (int64_t k = 0; k < md->m_band; ++k)
      if (!active[md->band_row[k]]) d->S[k * w] = 1.0;
  return md->m_band ? band_ldl(d->S, md->m_band, md->kd) : DL_OK;
}

/* The smallest pivot ratio of the factored S = Z^T Z (all rows active): each band
 * row's pivot against its diagonal before the factorization (gram_diagonal), the
 * squared sine of its angle to the rows before it. Small near a singular configuration
 * (numerics/singular.py); a cheap by-product of the projection's factorization. */
static double band_conditioning(const dl_model *md, const dl_data *d) {
  const int64_t w = md->kd + 1;
  double worst = INFINITY;
  for (int64_t k = 0; k < md->m_band; ++k) {
    const double g = d->gram_diagonal[k], inv = d->S[k * w];  /* inv = 1 / D_k */
    if (g > 0.0 && inv > 0.0 && 1.0 / (inv * g) < worst) worst = 1.0 / (inv * g);
  }
  return worst;
}

/* With M = I (the projections): z = a, copied (the elimination changes it), the internal
 * rows eliminated, S = Z^T Z over the active rows (others get a unit diagonal), factored:
 * kkt_factor's steps without the blocks' factors, which are the identity. */
int factor_schur(const dl_model *md, dl_data *d, const unsigned char *active) {
  double *z = d->y;
  memcpy(z, d->a, (size_t)md->pair_vec[md->n_pairs] * sizeof(double));
  d->factor.factored = 0;
  d->factor.active = active;
  for (int64_t k = 0; k < md->n_elim_blocks; ++k) {
    const int64_t b = md->elim_blocks[k];
    if (BY_SIZE(block_size(md, b), eliminate_internal, md, d, b, z, active) != DL_OK)
      return DL_SINGULAR_CONSTRAINTS;
  }
  clear_band(md, d);
  for (int64_t b = 0; b < md->n_blocks; ++b)
    BY_SIZE(block_size(md, b), gram_block, md, b, z, active, d->S);
  const int record = !active || md->n_hol == md->m, w = (int)(md->kd + 1);
  if (record)
    for (int64_t k = 0; k < md->m_band; ++k) d->gram_diagonal[k] = d->S[k * w];
  const int status = factor_band(md, d, active);
  if (record) d->conditioning = status == DL_OK ? band_conditioning(md, d) : 0.0;
  return status;
}

/* lam = S^-1 rhs over the band's rows (rhs by row, overwritten by lam), then
 * x += Z lam over the external pairs (x by slot). */
static void apply_multipliers(const dl_model *md, dl_data *d, const double *z, double *rhs,
                              double *x) {
  for (int64_t k = 0; k < md->m_band; ++k) d->r[k] = rhs[md->band_row[k]];
  band_solve(d->S, md->m_band, md->kd, d->r);
  for (int64_t k = 0; k < md->m_band; ++k) rhs[md->band_row[k]] = d->r[k];
  for (int64_t k = 0; k < md->n_unit_pairs; ++k)
    x[md->unit_pair_slot[k]] += z[md->unit_pair_vec[k]] * rhs[md->unit_pair_row[k]];
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b]) BY_SIZE(block_size(md, b), block_update, md, b, z, rhs, x);
}

/* With M = I: x = Z lam for the multipliers of rhs (by row, overwritten), from the
 * factor of factor_schur. */
void solve_schur(const dl_model *md, dl_data *d, double *rhs, double *x) {
  memset(x, 0, (size_t)md->n * sizeof(double));
  for (int64_t k = 0; k < md->n_elim_blocks; ++k) {
    const int64_t b = md->elim_blocks[k];
    BY_SIZE(block_size(md, b), eliminate_rhs, md, d, b, d->y, d->factor.active, rhs, x);
  }
  apply_multipliers(md, d, d->y, rhs, x);
}

/* Whether the band entry at place t = hi (kd + 1) + (hi - lo) joins two active rows. */
static int unit_gram_active(const dl_model *md, const unsigned char *active, int64_t t) {
  const int64_t w = md->kd + 1, hi = t / w;
  return active[md->band_row[hi]] && active[md->band_row[hi - t % w]];
}

/* The unit blocks' part of the factorization, in flat loops without per-block
 * branching: the same operations as fold_factor_block, block_forward, gram_block and
 * block_residual with nb = 1 (the block keeps 1 / L), only the order of the sums into S
 * and c differs. With c, the right-hand side's part too (u = L^-1 f, c - Z^T u). */
DL_INLINE int unit_factor(const dl_model *md, dl_data *d, const unsigned char *active,
                          double *c) {
  double *restrict blocks = d->blocks, *restrict u = d->u, *restrict z = d->y;
  const double *restrict a = d->a;
  for (int64_t k = 0; k < md->n_unit; ++k) {
    const double m = blocks[md->unit_mat[k]];
    if (!(m > 0.0)) return DL_SINGULAR_MASS;
    if (m != d->unit_mass[k]) {  /* most are constant (a mass, a planar body's inertia):
                                  * their roots and divisions are made once */
      d->unit_mass[k] = m;
      d->unit_root[k] = 1.0 / sqrt(m);
    }
    const double inv = d->unit_root[k];
    blocks[md->unit_mat[k]] = inv;
    if (c) u[md->unit_slot[k]] *= inv;
  }
  for (int64_t k = 0; k < md->n_unit_pairs; ++k) {
    const int64_t v = md->unit_pair_vec[k];
    z[v] = a[v] * blocks[md->unit_pair_mat[k]];
  }
  for (int64_t k = 0; k < md->n_unit_gram; ++k) {
    const int64_t t = md->unit_gram_target[k];
    if (active && !unit_gram_active(md, active, t)) continue;
    d->S[t] += z[md->unit_gram_i[k]] * z[md->unit_gram_j[k]];
  }
  if (c)
    for (int64_t k = 0; k < md->n_unit_pairs; ++k)
      c[md->unit_pair_row[k]] -= z[md->unit_pair_vec[k]] * u[md->unit_pair_slot[k]];
  return DL_OK;
}

/* Block b after its factor: z = L^-1 a, its active internal rows eliminated, its gram
 * products into S; with c, the right-hand side through the same steps (u = L^-1 f, the
 * pivots, c - Z^T u over its external pairs). */
DL_INLINE int block_pass(const dl_model *md, dl_data *d, int64_t b, const unsigned char *active,
                         double *c, int64_t nb) {
  block_forward(md, d, b, c != NULL, nb);
  if (md->block_external[b] > md->block_pairs[b]) {
    if (eliminate_internal(md, d, b, d->y, active, nb) != DL_OK) return DL_SINGULAR_CONSTRAINTS;
    if (c) eliminate_rhs(md, d, b, d->y, active, c, d->u, nb);
  }
  gram_block(md, b, d->y, active, d->S, nb);
  if (c) block_residual(md, b, d->y, d->u, c, nb);
  return DL_OK;
}

/* The one KKT factorization, with M in d->blocks and A in the pair vectors: each block
 * with its active internal rows folded in and factored, Z = L^-1 A^T, the active
 * internal rows eliminated, S = Z^T Z over the active band rows (the others get a unit
 * diagonal and no coupling), band LDL^T; its factors stay in d (blocks, y, elim, S,
 * factor.fold). active NULL is every row: the right-hand side's case, where no mask is
 * read. With c, the right-hand side [f (u, by slot); c] rides along in the same pass
 * (dl_solve), so the blocks are read once per evaluation. */
DL_INLINE int kkt_factor(const dl_model *md, dl_data *d, const unsigned char *active,
                         double *c) {
  d->factor.factored = 0;
  d->factor.active = active;
  clear_band(md, d);
  if (unit_factor(md, d, active, c) != DL_OK) return DL_SINGULAR_MASS;
  int status;
  /* the blocks factored first, in a loop of their own: the square roots and divisions
   * of one block's factorization are a chain, those of different blocks are not */
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b] &&
        BY_SIZE(block_size(md, b), fold_factor_block, md, d, b, active, c) != DL_OK)
      return DL_SINGULAR_MASS;
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b] &&
        (status = BY_SIZE(block_size(md, b), block_pass, md, d, b, active, c)) != DL_OK)
      return status;
  return factor_band(md, d, active);
}

/* After the band's right-hand side c (by row) is in place: lam = S^-1 c into c, then
 * x = L^-T (u + Z lam) in u (by slot). */
static void back_substitute(const dl_model *md, dl_data *d, double *c) {
  apply_multipliers(md, d, d->y, c, d->u);
  for (int64_t k = 0; k < md->n_unit; ++k) d->u[md->unit_slot[k]] *= d->blocks[md->unit_mat[k]];
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b]) BY_SIZE(block_size(md, b), block_backward, md, d, b, d->u);
}

/* The KKT values [M values, f, A values, c] of a flat kkt function into the solve's
 * layout (c stays where it is). */
static void load_kkt(const dl_model *md, dl_data *d) {
  const double *Mv = d->values, *f = Mv + md->nM;
  load_pairs(md, d, f + md->n);
  memset(d->blocks, 0, (size_t)md->block_mat[md->n_blocks] * sizeof(double));
  for (int64_t e = 0; e < md->nM; ++e) d->blocks[md->M_at[e]] += Mv[e];
  for (int64_t s = 0; s < md->n; ++s) d->u[s] = f[md->slot_coord[s]];
}

/* The model's inputs at (t, q, qd) into the parameter vector (none: nothing to do),
 * then the sliding contacts' friction forces (friction.c), which depend on them. */
int load_inputs(const dl_model *md, dl_data *d, double t, const double *q, const double *qd) {
  if (d->inputs) {
    memcpy(d->input_state, q, (size_t)md->n * sizeof(double));
    memcpy(d->input_state + md->n, qd, (size_t)md->n * sizeof(double));
    if (d->inputs(t) != 0) return DL_INPUT;
  }
  return d->friction ? load_friction(md, d, t, q, qd) : DL_OK;
}

/* The KKT values at (t, q, qd), in the solve's layout (the inputs set first). */
int eval_kkt(const dl_model *md, dl_data *d, double t, const double *q, const double *qd) {
  const int status = load_inputs(md, d, t, q, qd);
  if (status != DL_OK) return status;
  eval_state(&md->fn[DL_FN_KKT], t, q, qd, d->p, d->values);
  if (!md->kkt_in_layout) load_kkt(md, d);
  return DL_OK;
}

/* Whether qdd meets the dropped rows, A_d qdd = c_d, as closely as the Python loop asks
 * (kkt.py's DROPPED_ROW_RTOL, relative to 1 + max|c| + max|A| max|qdd|): a miss means
 * the rank changed since it was measured, and the reduced solve is no longer the
 * motion. The solve leaves c_d as it was (the dropped rows have no place in it). */
static int check_dropped(const dl_model *md, dl_data *d, const double *qdd, const double *c,
                         double c_max) {
  double *miss = d->lambda;  /* by row, free during a solve */
  const int64_t p0 = md->n_pairs, p1 = md->n_pairs + md->n_dropped_pairs;
  for (int64_t k = 0; k < md->n_dropped; ++k) miss[md->dropped_rows[k]] = -c[md->dropped_rows[k]];
  for (int64_t p = p0; p < p1; ++p) {
    const int64_t b = md->pair_block[p], nb = block_size(md, b), s0 = md->block_start[b];
    const double *a = d->a + md->pair_vec[p];
    for (int64_t i = 0; i < nb; ++i) miss[md->pair_row[p]] += a[i] * qdd[md->slot_coord[s0 + i]];
  }
  const double scale = 1.0 + c_max + max_abs(d->a, md->pair_vec[p1]) * max_abs(qdd, md->n);
  for (int64_t k = 0; k < md->n_dropped; ++k)
    if (!(fabs(miss[md->dropped_rows[k]]) <= md->dropped_rtol * scale)) return DL_RANK_CHANGED;
  return DL_OK;
}

/* qdd and lambda from the KKT values (eval_kkt; c modified in place): kkt_factor with
 * every row and the right-hand side along (S lam = c - Z^T u, Z = L^-1 A^T, u = L^-1 f),
 * then qdd = L^-T (u + Z lam). */
int dl_solve(const dl_model *md, dl_data *d, double *qdd, double *lambda) {
  double *c = d->c;
  /* the scale of check_dropped, before the solve overwrites the kept rows of c */
  const double c_max = md->n_dropped ? max_abs(c, md->m) : 0.0;
  int status = kkt_factor(md, d, NULL, c);
  if (status != DL_OK) return status;
  back_substitute(md, d, c);
  for (int64_t s = 0; s < md->n; ++s) qdd[md->slot_coord[s]] = d->u[s];
  if (md->n_dropped && (status = check_dropped(md, d, qdd, c, c_max)) != DL_OK) return status;
  if (lambda) {
    for (int64_t k = 0; k < md->n_elim_blocks; ++k)
      recover_internal(md, d, NULL, md->elim_blocks[k], c);
    memcpy(lambda, c, (size_t)md->m * sizeof(double));
    for (int64_t k = 0; k < md->n_dropped; ++k) lambda[md->dropped_rows[k]] = 0.0;
  }
  return DL_OK;
}

/* The Baumgarte terms: c -= 2 w (A qd + b) + w^2 psi (psi on holonomic rows). */
static void baumgarte(const dl_model *md, dl_data *d, double t, const double *q,
                      const double *qd, double *c) {
  const double g = md->baumgarte;
  eval_static(&md->fn[DL_FN_VELOCITY], t, q, d->p, d->vel_values);
  const double *b = d->vel_values + md->nA;
  for (int64_t r = 0; r < md->m; ++r) c[r] -= 2.0 * g * b[r];
  add_A_times(md, d, qd, -2.0 * g, c);
  eval_static(&md->fn[DL_FN_POSITION], t, q, d->p, d->psi);
  for (int64_t k = 0; k < md->n_hol; ++k) c[md->holonomic[k]] -= g * g * d->psi[k];
}

/* The KKT values at (t, y), evaluated again (a failed factorization overwrote them),
 * hold a NaN or an infinity: M (its blocks), f (u by slot) or c. */
static int kkt_values_not_finite(const dl_model *md, dl_data *d, double t, const double *y) {
  const int64_t n = md->n;
  if (eval_kkt(md, d, t, y, y + n) != DL_OK) return 0;
  if (md->baumgarte != 0.0 && md->m) baumgarte(md, d, t, y, y + n, d->c);
  return !all_finite(d->blocks, md->block_mat[md->n_blocks]) || !all_finite(d->u, n) ||
         !all_finite(d->c, md->m);
}

/* y' = [qd, qdd] at (t, y); lambda may be NULL. A factorization that fails on values
 * that are not finite (a force undefined at the state, a stage state gone NaN, a time
 * that overflows) is not a singular matrix: the accelerations are then NaN, as the
 * Python loop's solve gives them, so the step is cut and the loop names what is not
 * finite. Looked at only after a failure: nothing is added to the solves that work. */
int dl_rhs(const dl_model *md, dl_data *d, double t, const double *y, double *ydot,
           double *lambda) {
  const int64_t n = md->n;
  const int status = eval_kkt(md, d, t, y, y + n);
  if (status != DL_OK) return status;
  if (md->baumgarte != 0.0 && md->m) baumgarte(md, d, t, y, y + n, d->c);
  memcpy(ydot, y + n, (size_t)n * sizeof(double));
  const int solved = dl_solve(md, d, ydot + n, lambda);
  if ((solved == DL_SINGULAR_MASS || solved == DL_SINGULAR_CONSTRAINTS) &&
      kkt_values_not_finite(md, d, t, y)) {
    for (int64_t i = 0; i < n; ++i) ydot[n + i] = NAN;
    if (lambda)
      for (int64_t r = 0; r < md->m; ++r) lambda[r] = NAN;
    return DL_OK;
  }
  return solved;
}


/* ---- One factorization, many right-hand sides ----
 * dl_kkt_factor factors [[M, A^T], [A, 0]] for the values [M values, A values] (pattern
 * order) and the active rows (NULL: all) with kkt_factor, without a right-hand side.
 * dl_kkt_solve then takes k right-hand sides [f; c] (f by coordinate, c by row, the
 * inactive rows' entries ignored) to [qdd; lambda] with M qdd = f + A^T lambda,
 * A qdd = c on the active rows and lambda = 0 on the others, through the steps
 * dl_solve takes with its right-hand side. Another set of active rows is only another
 * dl_kkt_factor: nothing structural changes. */

int dl_kkt_factor(const dl_model *md, dl_data *d, const double *values,
                  const unsigned char *active) {
  dl_factor *fa = &d->factor;
  int all = md->n_dropped == 0;
  for (int64_t r = 0; r < md->m; ++r) all &= (fa->mask[r] = !active || active[r]);
  for (int64_t k = 0; k < md->n_dropped; ++k) fa->mask[md->dropped_rows[k]] = 0;
  memset(d->blocks, 0, (size_t)md->block_mat[md->n_blocks] * sizeof(double));
  for (int64_t e = 0; e < md->nM; ++e) d->blocks[md->M_at[e]] += values[e];
  load_pairs(md, d, values + md->nM);
  /* every row: the unmasked path, the one the loop's solves take */
  const int status = kkt_factor(md, d, all ? NULL : fa->mask, NULL);
  fa->factored = status == DL_OK;
  return status;
}

/* Block b's part of a right-hand side before the band solve, from the held factors:
 * u_b (f by slot) with the folded rows' w c_r a_r added, through L^-1, through the
 * internal pivots (eliminate_rhs), and c - Z^T u over its external pairs. */
DL_INLINE void solve_block_down(const dl_model *md, dl_data *d, int64_t b, double *c,
                                int64_t nb) {
  double *restrict ub = d->u + md->block_start[b];
  for (int64_t p = md->block_pairs[b]; p < md->block_external[b]; ++p) {
    if (d->factor.fold[p] == 0.0) continue;
    const double wc = d->factor.fold[p] * c[md->pair_row[p]];
    const double *restrict a = d->a + md->pair_vec[p];
    for (int64_t i = 0; i < nb; ++i) ub[i] += wc * a[i];
  }
  forward(d->blocks + md->block_mat[b], nb, ub);
  if (md->block_external[b] > md->block_pairs[b])
    eliminate_rhs(md, d, b, d->y, d->factor.active, c, d->u, nb);
  block_residual(md, b, d->y, d->u, c, nb);
}

/* One right-hand side [f; c] to [x; lam] (x by coordinate, lam by row). */
static void kkt_solve_one(const dl_model *md, dl_data *d, const double *f, const double *c_in,
                          double *x, double *lam) {
  const unsigned char *active = d->factor.active;
  double *c = d->factor.rows, *u = d->u;
  memcpy(c, c_in, (size_t)md->m * sizeof(double));
  for (int64_t s = 0; s < md->n; ++s) u[s] = f[md->slot_coord[s]];
  /* the unit blocks as unit_factor carries c along, then the others */
  for (int64_t k = 0; k < md->n_unit; ++k) u[md->unit_slot[k]] *= d->blocks[md->unit_mat[k]];
  for (int64_t k = 0; k < md->n_unit_pairs; ++k)
    c[md->unit_pair_row[k]] -= d->y[md->unit_pair_vec[k]] * u[md->unit_pair_slot[k]];
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b]) BY_SIZE(block_size(md, b), solve_block_down, md, d, b, c);
  /* the inactive rows' entries are ignored: their multipliers come out 0 (unit
   * diagonal, no coupling in S), so they add nothing to x */
  for (int64_t r = 0; r < md->m; ++r)
    if (!row_active(active, r)) c[r] = 0.0;
  back_substitute(md, d, c);
  for (int64_t s = 0; s < md->n; ++s) x[md->slot_coord[s]] = u[s];
  for (int64_t k = 0; k < md->n_elim_blocks; ++k)
    recover_internal(md, d, active, md->elim_blocks[k], c);
  for (int64_t r = 0; r < md->m; ++r) lam[r] = row_active(active, r) ? c[r] : 0.0;
}

/* k right-hand sides [f; c], ldr apart in rhs, to [qdd; lambda], ldr apart in out (rhs
 * and out may be the same); DL_SINGULAR_CONSTRAINTS without a factorization of
 * dl_kkt_factor's (the loop's solves and the projections replace the factors). */
int dl_kkt_solve(const dl_model *md, dl_data *d, int64_t k, const double *rhs, int64_t ldr,
                 double *out) {
  if (!d->factor.factored) return DL_SINGULAR_CONSTRAINTS;
  for (int64_t j = 0; j < k; ++j)
    kkt_solve_one(md, d, rhs + j * ldr, rhs + j * ldr + md->n, out + j * ldr,
                  out + j * ldr + md->n);
  return DL_OK;
}
