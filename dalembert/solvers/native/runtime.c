/* The simulation loop of dalembert in C: KKT solves, projection, Runge-Kutta steps.
 *
 * The model's generated functions (KKT blocks, velocity constraint, position
 * constraint) are called through pointers; everything else here is hand-written
 * and model independent. See native/__init__.py for the method and the tables.
 *
 * KKT solve (range-space / Schur complement, linear in the mechanism):
 *   M qdd = f + A^T lam,  A qdd = c.
 * M is block diagonal (one block per body). Rows lying inside one block (a
 * quaternion's unit norm) are folded into it, Mt = M_b + w a a^T, f_b += w a c_r:
 * true for every solution, and it makes a quaternion body's singular block
 * positive definite. Then, with Y = Mt^-1 A^T and u = Mt^-1 f,
 *   S lam = c - A u,  S = A Mt^-1 A^T (banded for chains and trees),  qdd = u + Y lam,
 * computed with the blocks' Cholesky factors Mt = L L^T as S = Z^T Z, Z = L^-1 A^T.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

enum { DL_OK = 0, DL_SINGULAR_MASS = 1, DL_SINGULAR_CONSTRAINTS = 2, DL_STEP_TOO_SMALL = 3,
       DL_PROJECTION = 4, DL_OUTPUTS = 5 };

typedef void (*scatter_state)(const int64_t *, const void *, const void *, const double *,
                              const double *, const double *, const double *, double *);
typedef void (*scatter_static)(const int64_t *, const void *, const void *, const double *,
                               const double *, const double *, double *);
typedef void (*flat_state)(const double *, const double *, const double *, const double *,
                           double *);
typedef void (*flat_static)(const double *, const double *, const double *, double *);

/* One generated function: a scatter driver (K != NULL, adds into out) or a flat one. */
typedef struct {
  void *fn;
  const int64_t *K;
  const void *index;
  const void *target;
  int64_t size;
} dl_function;

typedef struct {
  int64_t n, m, nM, nA, n_hol;
  const double *p;
  dl_function kkt, velocity, position, energy;
  const int64_t *holonomic;   /* n_hol: constraint row of each psi entry */
  double baumgarte;
  /* blocks of M: slots [block_start[b], block_start[b+1]) hold global coordinates */
  int64_t n_blocks;
  const int64_t *block_start, *slot_coord, *block_mat, *M_at;
  /* (row, block) pairs: the part of a constraint row inside one block, by block; a
   * block's internal pairs (rows inside it) first: [block_pairs[b], block_external[b]) */
  int64_t n_pairs;
  const int64_t *pair_row, *pair_block, *pair_vec, *A_at, *block_pairs, *block_external;
  const int64_t *elim_at;     /* an internal pair's factors in elim (eliminate_internal) */
  int64_t n_elim_blocks;
  const int64_t *elim_blocks; /* the blocks with internal pairs */
  /* Schur complement of the other rows in band storage, band_row[k] at place k */
  int64_t m_band, kd;
  const int64_t *band_row;
  const int64_t *gram_start, *gram_target;  /* per block: band place of z_i . z_j, j <= i,
                                             * over its external pairs */
  /* the 1 x 1 blocks without internal rows, solved in flat loops (see unit_pass) */
  const int64_t *unit;        /* n_blocks: 1 for such a block */
  int64_t n_unit, n_unit_pairs, n_unit_gram;
  const int64_t *unit_slot, *unit_mat;                      /* n_unit */
  const int64_t *unit_pair_vec, *unit_pair_row, *unit_pair_slot, *unit_pair_mat;
  const int64_t *unit_gram_target, *unit_gram_i, *unit_gram_j;  /* n_unit_gram */
  /* work arrays */
  double *values, *vel_values, *psi, *blocks, *a, *y, *u, *S, *r, *lambda, *qdd, *q_trial;
  double *elim, *error_work;  /* error_work: 4 n */
  const unsigned char *active;  /* the rows S was last factored with (NULL: all) */
  /* kkt_in_layout: the kkt function writes straight into blocks (M), u (f by slot), a
   * (A) and c, all inside values; else values is [M, f, A, c] and load_kkt moves them */
  int64_t kkt_in_layout;
  double *c;                  /* the KKT right-hand side (in values) */
} dl_model;

static void eval_state(const dl_function *F, double t, const double *q, const double *qd,
                       const double *p, double *out) {
  if (F->size == 0) return;
  if (F->K) {
    memset(out, 0, (size_t)F->size * sizeof(double));
    ((scatter_state)F->fn)(F->K, F->index, F->target, &t, q, qd, p, out);
  } else {
    ((flat_state)F->fn)(&t, q, qd, p, out);
  }
}

static void eval_static(const dl_function *F, double t, const double *q, const double *p,
                        double *out) {
  if (F->size == 0) return;
  if (F->K) {
    memset(out, 0, (size_t)F->size * sizeof(double));
    ((scatter_static)F->fn)(F->K, F->index, F->target, &t, q, p, out);
  } else {
    ((flat_static)F->fn)(&t, q, p, out);
  }
}

/* Small helpers are inlined where the block size is a constant (see BY_SIZE). */
#define DL_INLINE static inline __attribute__((always_inline))

DL_INLINE double dot(const double *x, const double *y, int64_t n) {
  double s = 0.0;
  for (int64_t i = 0; i < n; ++i) s += x[i] * y[i];
  return s;
}

/* Cholesky of a dense n x n block in place (lower triangle, row major); the diagonal
 * keeps 1 / L_jj, so the solves multiply instead of divide. */
DL_INLINE int cholesky(double *L, int64_t n) {
  for (int64_t j = 0; j < n; ++j) {
    double d = L[j * n + j];
    const double scale = fabs(d);
    for (int64_t k = 0; k < j; ++k) d -= L[j * n + k] * L[j * n + k];
    if (!(d > 1e-14 * scale) || !(d > 0.0)) return DL_SINGULAR_MASS;
    const double inv = 1.0 / sqrt(d);
    L[j * n + j] = inv;
    for (int64_t i = j + 1; i < n; ++i) {
      double s = L[i * n + j];
      for (int64_t k = 0; k < j; ++k) s -= L[i * n + k] * L[j * n + k];
      L[i * n + j] = s * inv;
    }
  }
  return DL_OK;
}

/* x <- L^-1 x */
DL_INLINE void forward(const double *L, int64_t n, double *x) {
  for (int64_t i = 0; i < n; ++i) {
    double s = x[i];
    for (int64_t k = 0; k < i; ++k) s -= L[i * n + k] * x[k];
    x[i] = s * L[i * n + i];
  }
}

/* x <- L^-T x */
DL_INLINE void backward(const double *L, int64_t n, double *x) {
  for (int64_t i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int64_t k = i + 1; k < n; ++k) s -= L[k * n + i] * x[k];
    x[i] = s * L[i * n + i];
  }
}

/* Band Cholesky: S[i * (kd + 1) + (i - j)] holds S_ij for i - kd <= j <= i; the
 * diagonal keeps 1 / L_jj. */
static int band_cholesky(double *S, int64_t m, int64_t kd) {
  const int64_t w = kd + 1;
  for (int64_t j = 0; j < m; ++j) {
    const int64_t k0 = j > kd ? j - kd : 0;
    double *Sj = S + j * w + j;  /* Sj[-k] = S_jk */
    double d = Sj[-j];
    const double scale = fabs(d);
    for (int64_t k = k0; k < j; ++k) d -= Sj[-k] * Sj[-k];
    if (!(d > 1e-14 * scale) || !(d > 0.0)) return DL_SINGULAR_CONSTRAINTS;
    const double inv = 1.0 / sqrt(d);
    Sj[-j] = inv;
    const int64_t i1 = j + kd < m - 1 ? j + kd : m - 1;
    for (int64_t i = j + 1; i <= i1; ++i) {
      double *Si = S + i * w + i;
      const int64_t kk = i > kd ? i - kd : 0;
      double s = Si[-j];
      for (int64_t k = kk; k < j; ++k) s -= Si[-k] * Sj[-k];
      Si[-j] = s * inv;
    }
  }
  return DL_OK;
}

static void band_solve(const double *S, int64_t m, int64_t kd, double *x) {
  const int64_t w = kd + 1;
  for (int64_t i = 0; i < m; ++i) {
    const int64_t k0 = i > kd ? i - kd : 0;
    const double *Si = S + i * w + i;
    double s = x[i];
    for (int64_t k = k0; k < i; ++k) s -= Si[-k] * x[k];
    x[i] = s * Si[-i];
  }
  for (int64_t i = m - 1; i >= 0; --i) {
    const int64_t k1 = i + kd < m - 1 ? i + kd : m - 1;
    double s = x[i];
    for (int64_t k = i + 1; k <= k1; ++k) s -= S[k * w + (k - i)] * x[k];
    x[i] = s * S[i * w];
  }
}

static int64_t block_size(const dl_model *md, int64_t b) {
  return md->block_start[b + 1] - md->block_start[b];
}

/* The per-block kernels below take the block size nb last; BY_SIZE calls them with a
 * constant nb for the common small blocks (a diagonal M has 1x1 blocks, a quaternion
 * body a 4x4 one), so the compiler unrolls their loops and inlines the helpers. */
#define BY_SIZE(nb, F, ...)                                                               \
  ((nb) == 1 ? F(__VA_ARGS__, 1) : (nb) == 2 ? F(__VA_ARGS__, 2)                          \
   : (nb) == 3 ? F(__VA_ARGS__, 3) : (nb) == 4 ? F(__VA_ARGS__, 4) : F(__VA_ARGS__, nb))

/* Scatter the values of A (pattern order) into the pair vectors. Nothing else writes
 * them, so the slots no value lands in keep the zeros they were allocated with. */
static void load_pairs(dl_model *md, const double *Av) {
  for (int64_t e = 0; e < md->nA; ++e) md->a[md->A_at[e]] = Av[e];
}

/* out[r] += w (A x)_r, with A in the pair vectors and x by global coordinate. */
static void add_A_times(const dl_model *md, const double *x, double w, double *out) {
  for (int64_t p = 0; p < md->n_pairs; ++p) {
    const int64_t b = md->pair_block[p], nb = block_size(md, b), s0 = md->block_start[b];
    const double *a = md->a + md->pair_vec[p];
    double s = 0.0;
    for (int64_t i = 0; i < nb; ++i) s += a[i] * x[md->slot_coord[s0 + i]];
    out[md->pair_row[p]] += w * s;
  }
}

/* Block b of M (scattered) with its internal rows folded in, factored (Mt = L L^T);
 * u_b = L^-1 f_b and z_p = L^-1 a_p for its pairs. */
DL_INLINE int factor_block(dl_model *md, int64_t b, const double *c, int64_t nb) {
  double *restrict B = md->blocks + md->block_mat[b];
  double *restrict u = md->u + md->block_start[b];
  double trace = 0.0;
  for (int64_t i = 0; i < nb; ++i) trace += B[i * nb + i];
  const int64_t p0 = md->block_pairs[b], p1 = md->block_pairs[b + 1];
  for (int64_t p = p0; p < md->block_external[b]; ++p) {
    const double *restrict a = md->a + md->pair_vec[p];
    const double norm2 = dot(a, a, nb);
    if (norm2 == 0.0) continue;
    const double w = trace > 0.0 ? trace / (nb * norm2) : 1.0 / norm2;
    const double wc = w * c[md->pair_row[p]];
    for (int64_t i = 0; i < nb; ++i) {
      u[i] += wc * a[i];
      for (int64_t j = 0; j <= i; ++j) B[i * nb + j] += w * a[i] * a[j];
    }
  }
  if (cholesky(B, nb) != DL_OK) return DL_SINGULAR_MASS;
  forward(B, nb, u);
  const double *restrict a = md->a + md->pair_vec[p0];
  double *restrict z = md->y + md->pair_vec[p0];
  for (int64_t k = 0; k < (p1 - p0) * nb; ++k) z[k] = a[k];
  for (int64_t k = 0; k < p1 - p0; ++k) forward(B, nb, z + k * nb);
  return DL_OK;
}

DL_INLINE int is_active(const unsigned char *active, const dl_model *md, int64_t p) {
  return !active || active[md->pair_row[p]];
}

/* Block b's internal rows (its first pairs; the active ones) eliminated from S, one
 * Gaussian pivot after the other: each later pair of the block loses its part along
 * the pivot (z_p -= alpha z_i, alpha = z_i.z_p / z_i.z_i), so that Z^T Z over the
 * block's external pairs is S with the pivots eliminated. elim keeps, per pivot,
 * 1 / z_i.z_i and the alphas (for eliminate_rhs and recover_internal). */
DL_INLINE int eliminate_internal(dl_model *md, int64_t b, double *z,
                                 const unsigned char *active, int64_t nb) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  const int several = pe - p0 > 1;
  if (several)  /* the pivots' scales, before any elimination (one pivot: its own) */
    for (int64_t i = p0; i < pe; ++i)
      if (is_active(active, md, i))
        md->elim[md->elim_at[i]] = dot(z + md->pair_vec[i], z + md->pair_vec[i], nb);
  for (int64_t i = p0; i < pe; ++i) {
    if (!is_active(active, md, i)) continue;
    const double *restrict zi = z + md->pair_vec[i];
    double *restrict e = md->elim + md->elim_at[i];
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
DL_INLINE void eliminate_rhs(const dl_model *md, int64_t b, const double *z,
                             const unsigned char *active, double *c, double *u, int64_t nb) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  double *restrict ub = u + md->block_start[b];
  for (int64_t i = p0; i < pe; ++i) {
    if (!is_active(active, md, i)) continue;
    const double *restrict zi = z + md->pair_vec[i], *restrict e = md->elim + md->elim_at[i];
    const double ci = c[md->pair_row[i]];
    for (int64_t p = i + 1; p < p1; ++p)
      if (is_active(active, md, p)) c[md->pair_row[p]] -= e[p - i] * ci;
    const double beta = (ci - dot(zi, ub, nb)) * e[0];
    for (int64_t k = 0; k < nb; ++k) ub[k] += beta * zi[k];
    c[md->pair_row[i]] = beta;
  }
}

/* The multipliers of block b's internal rows from the others', last pivot first:
 * lam_i = beta_i - sum over the later rows of alpha lam_p (after dl_solve's elimination,
 * all rows active; the projections do not need these multipliers). */
static void recover_internal(const dl_model *md, int64_t b, double *lam) {
  const int64_t p0 = md->block_pairs[b], pe = md->block_external[b], p1 = md->block_pairs[b + 1];
  for (int64_t i = pe - 1; i >= p0; --i) {
    const double *e = md->elim + md->elim_at[i];
    double l = lam[md->pair_row[i]];
    for (int64_t p = i + 1; p < p1; ++p) l -= e[p - i] * lam[md->pair_row[p]];
    lam[md->pair_row[i]] = l;
  }
}

/* S += Z_b^T Z_b over the block's external pairs and the active rows (all when active is
 * NULL); block b's pair vectors z are contiguous, nb values each. */
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
  for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p)
    rhs[md->pair_row[p]] -= dot(z + md->pair_vec[p], xb, nb);
}

/* x_b += Z_b lam over block b's external pairs (x by slot, lam by row). */
DL_INLINE void block_update(const dl_model *md, int64_t b, const double *z, const double *lam,
                            double *x, int64_t nb) {
  double *restrict xb = x + md->block_start[b];
  for (int64_t p = md->block_external[b]; p < md->block_pairs[b + 1]; ++p) {
    const double l = lam[md->pair_row[p]];
    const double *restrict zp = z + md->pair_vec[p];
    for (int64_t i = 0; i < nb; ++i) xb[i] += zp[i] * l;
  }
}

/* x_b <- L_b^-T x_b (x by slot). */
DL_INLINE void block_backward(const dl_model *md, int64_t b, double *x, int64_t nb) {
  backward(md->blocks + md->block_mat[b], nb, x + md->block_start[b]);
}

static void clear_band(dl_model *md) {
  memset(md->S, 0, (size_t)(md->m_band * (md->kd + 1)) * sizeof(double));
}

/* The rows the gram products leave out get a unit diagonal; S factored. */
static int factor_band(dl_model *md, const unsigned char *active) {
  const int64_t w = md->kd + 1;
  if (active)
    for (int64_t k = 0; k < md->m_band; ++k)
      if (!active[md->band_row[k]]) md->S[k * w] = 1.0;
  return md->m_band ? band_cholesky(md->S, md->m_band, md->kd) : DL_OK;
}

/* With M = I (the projections): z = a, copied (the elimination changes it), the internal
 * rows eliminated, S = Z^T Z over the active rows (others get a unit diagonal), factored. */
static int factor_schur(dl_model *md, const unsigned char *active) {
  double *z = md->y;
  memcpy(z, md->a, (size_t)md->pair_vec[md->n_pairs] * sizeof(double));
  md->active = active;
  for (int64_t k = 0; k < md->n_elim_blocks; ++k) {
    const int64_t b = md->elim_blocks[k];
    if (BY_SIZE(block_size(md, b), eliminate_internal, md, b, z, active) != DL_OK)
      return DL_SINGULAR_CONSTRAINTS;
  }
  clear_band(md);
  for (int64_t b = 0; b < md->n_blocks; ++b)
    BY_SIZE(block_size(md, b), gram_block, md, b, z, active, md->S);
  return factor_band(md, active);
}

/* lam = S^-1 rhs over the band's rows (rhs by row, overwritten by lam), then
 * x += Z lam over the external pairs (x by slot). */
static void apply_multipliers(dl_model *md, const double *z, double *rhs, double *x) {
  for (int64_t k = 0; k < md->m_band; ++k) md->r[k] = rhs[md->band_row[k]];
  band_solve(md->S, md->m_band, md->kd, md->r);
  for (int64_t k = 0; k < md->m_band; ++k) rhs[md->band_row[k]] = md->r[k];
  for (int64_t k = 0; k < md->n_unit_pairs; ++k)
    x[md->unit_pair_slot[k]] += z[md->unit_pair_vec[k]] * rhs[md->unit_pair_row[k]];
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b]) BY_SIZE(block_size(md, b), block_update, md, b, z, rhs, x);
}

/* With M = I: x = Z lam for the multipliers of rhs (by row, overwritten), from the
 * factor of factor_schur. */
static void solve_schur(dl_model *md, double *rhs, double *x) {
  memset(x, 0, (size_t)md->n * sizeof(double));
  for (int64_t k = 0; k < md->n_elim_blocks; ++k) {
    const int64_t b = md->elim_blocks[k];
    BY_SIZE(block_size(md, b), eliminate_rhs, md, b, md->y, md->active, rhs, x);
  }
  apply_multipliers(md, md->y, rhs, x);
}

/* The unit blocks' part of block_pass, in flat loops without per-block branching: the
 * same operations as factor_block, gram_block and block_residual with nb = 1 (the
 * block keeps 1 / L), only the order of the sums into S and c differs. */
static int unit_pass(dl_model *md, double *c) {
  double *restrict blocks = md->blocks, *restrict u = md->u, *restrict z = md->y;
  const double *restrict a = md->a;
  for (int64_t k = 0; k < md->n_unit; ++k) {
    const double d = blocks[md->unit_mat[k]];
    if (!(d > 0.0)) return DL_SINGULAR_MASS;
    const double inv = 1.0 / sqrt(d);
    blocks[md->unit_mat[k]] = inv;
    u[md->unit_slot[k]] *= inv;
  }
  for (int64_t k = 0; k < md->n_unit_pairs; ++k) {
    const int64_t v = md->unit_pair_vec[k];
    z[v] = a[v] * blocks[md->unit_pair_mat[k]];
  }
  for (int64_t k = 0; k < md->n_unit_gram; ++k)
    md->S[md->unit_gram_target[k]] += z[md->unit_gram_i[k]] * z[md->unit_gram_j[k]];
  for (int64_t k = 0; k < md->n_unit_pairs; ++k)
    c[md->unit_pair_row[k]] -= z[md->unit_pair_vec[k]] * u[md->unit_pair_slot[k]];
  return DL_OK;
}

/* Block b factored, its internal rows eliminated, its gram products into S and its
 * part of c - Z^T u. */
DL_INLINE int block_pass(dl_model *md, int64_t b, double *c, int64_t nb) {
  if (factor_block(md, b, c, nb) != DL_OK) return DL_SINGULAR_MASS;
  if (md->block_external[b] > md->block_pairs[b]) {
    if (eliminate_internal(md, b, md->y, NULL, nb) != DL_OK) return DL_SINGULAR_CONSTRAINTS;
    eliminate_rhs(md, b, md->y, NULL, c, md->u, nb);
  }
  gram_block(md, b, md->y, NULL, md->S, nb);
  block_residual(md, b, md->y, md->u, c, nb);
  return DL_OK;
}

/* The KKT values [M values, f, A values, c] of a flat kkt function into the solve's
 * layout (c stays where it is). */
static void load_kkt(dl_model *md) {
  const double *Mv = md->values, *f = Mv + md->nM;
  load_pairs(md, f + md->n);
  memset(md->blocks, 0, (size_t)md->block_mat[md->n_blocks] * sizeof(double));
  for (int64_t e = 0; e < md->nM; ++e) md->blocks[md->M_at[e]] += Mv[e];
  for (int64_t s = 0; s < md->n; ++s) md->u[s] = f[md->slot_coord[s]];
}

/* The KKT values at (t, q, qd), in the solve's layout. */
static void eval_kkt(dl_model *md, double t, const double *q, const double *qd) {
  eval_state(&md->kkt, t, q, qd, md->p, md->values);
  if (!md->kkt_in_layout) load_kkt(md);
}

/* qdd and lambda from the KKT values (eval_kkt; c modified in place): S lam = c - Z^T u
 * with Z = L^-1 A^T, u = L^-1 f, then qdd = L^-T (u + Z lam). One pass over the blocks
 * factors them, eliminates their internal rows and builds S and the right-hand side. */
static int dl_solve(dl_model *md, double *qdd, double *lambda) {
  double *c = md->c;
  clear_band(md);
  if (unit_pass(md, c) != DL_OK) return DL_SINGULAR_MASS;
  int status;
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b] && (status = BY_SIZE(block_size(md, b), block_pass, md, b, c)) != DL_OK)
      return status;
  if ((status = factor_band(md, NULL)) != DL_OK) return status;
  apply_multipliers(md, md->y, c, md->u);
  for (int64_t k = 0; k < md->n_unit; ++k) md->u[md->unit_slot[k]] *= md->blocks[md->unit_mat[k]];
  for (int64_t b = 0; b < md->n_blocks; ++b)
    if (!md->unit[b]) BY_SIZE(block_size(md, b), block_backward, md, b, md->u);
  for (int64_t s = 0; s < md->n; ++s) qdd[md->slot_coord[s]] = md->u[s];
  if (lambda) {
    for (int64_t k = 0; k < md->n_elim_blocks; ++k) recover_internal(md, md->elim_blocks[k], c);
    memcpy(lambda, c, (size_t)md->m * sizeof(double));
  }
  return DL_OK;
}

/* The Baumgarte terms: c -= 2 w (A qd + b) + w^2 psi (psi on holonomic rows). */
static void baumgarte(dl_model *md, double t, const double *q, const double *qd, double *c) {
  const double g = md->baumgarte;
  eval_static(&md->velocity, t, q, md->p, md->vel_values);
  const double *b = md->vel_values + md->nA;
  for (int64_t r = 0; r < md->m; ++r) c[r] -= 2.0 * g * b[r];
  add_A_times(md, qd, -2.0 * g, c);
  eval_static(&md->position, t, q, md->p, md->psi);
  for (int64_t k = 0; k < md->n_hol; ++k) c[md->holonomic[k]] -= g * g * md->psi[k];
}

/* y' = [qd, qdd] at (t, y); lambda may be NULL. */
int dl_rhs(dl_model *md, double t, const double *y, double *ydot, double *lambda) {
  const int64_t n = md->n;
  eval_kkt(md, t, y, y + n);
  if (md->baumgarte != 0.0 && md->m) baumgarte(md, t, y, y + n, md->c);
  memcpy(ydot, y + n, (size_t)n * sizeof(double));
  return dl_solve(md, ydot + n, lambda);
}

/* ---- projection onto the constraints (minimum-norm changes) ---------------------- */

static double max_abs(const double *x, int64_t n) {
  double m = 0.0;
  for (int64_t i = 0; i < n; ++i) m = fabs(x[i]) > m ? fabs(x[i]) : m;
  return m;
}

/* Outputs at k states Y (rows [q, qd]): qdd, lambda (no stabilization terms), the
 * constraint force A^T lambda, the largest position and velocity residuals, and the
 * energies [T, V, h]. */
int dl_outputs(dl_model *md, int64_t k, const double *times, const double *Y, double *qdd,
               double *lambda, double *force, double *position_residual,
               double *velocity_residual, double *energies) {
  const int64_t n = md->n, m = md->m;
  for (int64_t i = 0; i < k; ++i) {
    const double t = times[i], *q = Y + i * 2 * n, *qd = q + n;
    eval_kkt(md, t, q, qd);
    const int status = dl_solve(md, qdd + i * n, lambda + i * m);
    if (status != DL_OK) return status;
    double *F = force + i * n;
    const double *lam = lambda + i * m;
    memset(F, 0, (size_t)n * sizeof(double));
    eval_static(&md->velocity, t, q, md->p, md->vel_values);
    double *vres = md->lambda;  /* A qd + b by row */
    for (int64_t r = 0; r < m; ++r) vres[r] = md->vel_values[md->nA + r];
    add_A_times(md, qd, 1.0, vres);
    for (int64_t p = 0; p < md->n_pairs; ++p) {  /* F = A^T lam */
      const int64_t b = md->pair_block[p], nb = block_size(md, b), s0 = md->block_start[b];
      const double *a = md->a + md->pair_vec[p];
      for (int64_t j = 0; j < nb; ++j) F[md->slot_coord[s0 + j]] += a[j] * lam[md->pair_row[p]];
    }
    velocity_residual[i] = max_abs(vres, m);
    eval_static(&md->position, t, q, md->p, md->psi);
    position_residual[i] = max_abs(md->psi, md->n_hol);
    eval_state(&md->energy, t, q, qd, md->p, energies + 3 * i);
  }
  return DL_OK;
}

/* Least-change step dq = -J^T (J J^T)^-1 psi with the factored S = J J^T. */
static void position_step(dl_model *md, const double *psi, double *dq) {
  memset(md->lambda, 0, (size_t)md->m * sizeof(double));
  for (int64_t k = 0; k < md->n_hol; ++k) md->lambda[md->holonomic[k]] = -psi[k];
  solve_schur(md, md->lambda, md->u);
  for (int64_t s = 0; s < md->n; ++s) dq[md->slot_coord[s]] = md->u[s];
}

/* J J^T at q factored (holonomic rows). */
static int factor_positions(dl_model *md, double t, const double *q,
                            const unsigned char *holonomic) {
  eval_static(&md->velocity, t, q, md->p, md->vel_values);
  load_pairs(md, md->vel_values);
  return factor_schur(md, holonomic) == DL_OK ? DL_OK : DL_PROJECTION;
}

/* Newton on psi(q, t) = 0, as StepProjector.positions: simplified (one factorization)
 * for max_newton iterations, then, if that stalls above the rounding floor (a state
 * far from the constraints, such as a coarse step's interpolant), full Newton for up to
 * max_full more. *moved: the largest change of a coordinate (0 if none was made). */
static int project_positions(dl_model *md, double t, double *q, const unsigned char *holonomic,
                             int64_t max_newton, int64_t max_full, double position_tol,
                             double accept_tol, double *moved) {
  const int64_t n = md->n;
  double *psi = md->psi, *trial = md->q_trial, *dq = md->qdd;
  *moved = 0.0;
  eval_static(&md->position, t, q, md->p, psi);
  double residual = max_abs(psi, md->n_hol);
  if (residual <= position_tol) return DL_OK;
  if (factor_positions(md, t, q, holonomic) != DL_OK) return DL_PROJECTION;
  for (int64_t it = 0; it < max_newton + max_full; ++it) {
    if (it >= max_newton) {  /* full Newton: psi at q again, J at q */
      eval_static(&md->position, t, q, md->p, psi);
      if (factor_positions(md, t, q, holonomic) != DL_OK) return DL_PROJECTION;
    }
    position_step(md, psi, dq);
    const double step = max_abs(dq, n);
    *moved = step > *moved ? step : *moved;
    for (int64_t i = 0; i < n; ++i) trial[i] = q[i] + dq[i];
    eval_static(&md->position, t, trial, md->p, psi);
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
static int project_velocities(dl_model *md, double t, const double *q, double *qd,
                              int refactor) {
  eval_static(&md->velocity, t, q, md->p, md->vel_values);
  load_pairs(md, md->vel_values);
  if (refactor && factor_schur(md, NULL) != DL_OK) return DL_PROJECTION;
  const double *b = md->vel_values + md->nA;
  /* lambda = -(A qd + b): the residual, by row */
  for (int64_t r = 0; r < md->m; ++r) md->lambda[r] = -b[r];
  add_A_times(md, qd, -1.0, md->lambda);
  solve_schur(md, md->lambda, md->u);
  for (int64_t s = 0; s < md->n; ++s) qd[md->slot_coord[s]] += md->u[s];
  return DL_OK;
}

/* y = [q, qd] projected in place: positions (holonomic rows), then velocities. */
int dl_project(dl_model *md, double t, double *y, const unsigned char *holonomic,
               int64_t max_newton, int64_t max_full, double position_tol, double accept_tol) {
  if (md->m == 0) return DL_OK;
  double moved = 0.0;
  if (md->n_hol) {
    const int status = project_positions(md, t, y, holonomic, max_newton, max_full,
                                         position_tol, accept_tol, &moved);
    if (status != DL_OK) return status;
  }
  const double scale = max_abs(y, md->n) > 1.0 ? max_abs(y, md->n) : 1.0;
  const int reuse = md->n_hol == md->m && moved > 0.0 && moved <= 1e-6 * scale;
  return project_velocities(md, t, y, y + md->n, !reuse);
}

/* ---- one accepted explicit Runge-Kutta step, as scipy.integrate's RungeKutta ------ */

typedef struct {
  int64_t n_stages;           /* s: K has s + 1 rows (the last is f at the new point) */
  const double *A, *B, *C;    /* A: s x s row major, B and C: s */
  const double *E;            /* s + 1: error weights (E5 for DOP853) */
  const double *E3;           /* DOP853's second estimator, or NULL */
  /* The step's interpolant (scipy's dense output), used by dl_rk_run: either
   * RkDenseOutput's P ((s + 1) x n_P), or DOP853's n_extra extra stages (A_extra:
   * n_extra rows of length s + 1 + n_extra, C_extra) and D (n_D rows, same length). */
  int64_t n_P;
  const double *P;
  int64_t n_extra;
  const double *A_extra, *C_extra;
  int64_t n_D;
  const double *D;
} dl_tableau;

typedef struct {
  double t, h_abs, h_previous, t_bound, direction, rtol, max_step;
  const double *atol;         /* n_state */
  int64_t nfev;
  double alpha, beta;         /* the controller, step_control.py: h *= 0.9 err^-alpha */
  double err_old;             /* err_old^beta, err_old the last accepted step's error */
} dl_stepper;

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
  for (int64_t i = 0; i < n_state; ++i) {
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
int dl_stages(dl_model *md, const double *A, int64_t lda, const double *C, int64_t row0,
              int64_t j0, int64_t j1, double t, double h, const double *y, double *K,
              double *stage, int64_t *nfev) {
  const int64_t n_state = 2 * md->n;
  for (int64_t j = j0; j < j1; ++j) {
    combine(y, h, K, A + (j - row0) * lda, j, n_state, stage);
    ++*nfev;
    const int status = dl_rhs(md, t + C[j - row0] * h, stage, K + j * n_state, NULL);
    if (status != DL_OK) return status;
  }
  return DL_OK;
}

/* One Runge-Kutta step from (st->t, y, f = K[0] on entry): y_new, f_new = K[s]. */
static int rk_attempt(dl_model *md, const dl_tableau *tb, dl_stepper *st, double h,
                      const double *y, double *K, double *y_new, double *stage) {
  const int64_t n_state = 2 * md->n, s = tb->n_stages;
  const int status = dl_stages(md, tb->A, s, tb->C, 0, 1, s, st->t, h, y, K, stage, &st->nfev);
  if (status != DL_OK) return status;
  combine(y, h, K, tb->B, s, n_state, y_new);
  st->nfev++;
  return dl_rhs(md, st->t + h, y_new, K + s * n_state, NULL);
}

/* Steps from st->t until one is accepted (ControlledSteps._step_impl, which is scipy's
 * RungeKutta._step_impl under PI control; scipy's own with beta = 0). K[0] must hold
 * f(t, y) on entry; on return y_new, K[s] = f(t_new, y_new) and st is advanced. */
int dl_rk_step(dl_model *md, const dl_tableau *tb, dl_stepper *st, const double *y, double *K,
               double *y_new, double *stage) {
  const double SAFETY = 0.9, MIN_FACTOR = 0.2, MAX_FACTOR = 10.0, ERROR_FLOOR = 1e-4;
  const int64_t n_state = 2 * md->n;
  const double t = st->t;
  const double min_step = 10.0 * fabs(nextafter(t, st->direction * INFINITY) - t);
  double h_abs = st->h_abs;
  if (h_abs > st->max_step) h_abs = st->max_step;
  else if (h_abs < min_step) h_abs = min_step;
  int rejected = 0;
  for (;;) {
    if (h_abs < min_step) return DL_STEP_TOO_SMALL;
    double t_new = t + h_abs * st->direction;
    if (st->direction * (t_new - st->t_bound) > 0) t_new = st->t_bound;
    const double h = t_new - t;
    h_abs = fabs(h);
    const int status = rk_attempt(md, tb, st, h, y, K, y_new, stage);
    if (status != DL_OK) return status;
    for (int64_t i = 0; i < n_state; ++i) {
      const double big = fabs(y[i]) > fabs(y_new[i]) ? fabs(y[i]) : fabs(y_new[i]);
      stage[i] = st->atol[i] + big * st->rtol;
    }
    const double err = error_norm(tb, K, n_state, h, stage, md->error_work);
    if (err < 1.0) {
      double factor = err == 0.0 ? MAX_FACTOR
                                 : SAFETY * pow(err, -st->alpha) * pow(st->err_old, st->beta);
      if (factor > MAX_FACTOR) factor = MAX_FACTOR;
      st->err_old = err > ERROR_FLOOR ? err : ERROR_FLOOR;
      if (rejected && factor > 1.0) factor = 1.0;
      st->h_abs = h_abs * factor;
      st->h_previous = h;
      st->t = t_new;
      return DL_OK;
    }
    const double shrink = SAFETY * pow(err, -st->alpha);
    h_abs *= shrink > MIN_FACTOR ? shrink : MIN_FACTOR;
    rejected = 1;
  }
}

/* ---- whole stretches of steps: step, projection, outputs, restart --------------- */

/* One call of dl_rk_run: where the outputs go, how to project, when to return. */
typedef struct {
  const double *t_eval;       /* n_eval output times in the direction of integration, or
                               * n_eval < 0: every step end */
  int64_t n_eval, next_eval;  /* next_eval: the first output time after st->t */
  const unsigned char *holonomic;  /* dl_project's arguments */
  int64_t max_newton, max_full;
  double position_tol, accept_tol;
  int64_t max_steps;          /* budget of one call: steps, and CPU seconds */
  double max_seconds;
  int64_t capacity;           /* rows of t_out and y_out */
  double *t_out, *y_out;
  int64_t n_steps, n_out;     /* done by this call */
  double t_old;               /* the start of its last step */
  double *y_new, *y_end;      /* work, n_state each */
  double *rows;               /* work: the interpolant, max(n_P, n_D + 3) rows of n_state */
} dl_run;

/* The interpolant of the step t_old -> t_old + h from the solver state before the
 * restart (y_old, the unprojected y_new, the stages K), made as scipy makes it:
 * rows = (K^T P)^T for RkDenseOutput; for DOP853 the extra stages go into K, then
 * rows = F: [dy, h f_old - dy, 2 dy - h (f_new + f_old), h D K]. */
static int make_interpolant(dl_model *md, const dl_tableau *tb, dl_stepper *st, double t_old,
                            double h, const double *y_old, const double *y_new, double *K,
                            double *rows, double *stage) {
  const int64_t n_state = 2 * md->n, s1 = tb->n_stages + 1;
  if (!tb->n_extra) {
    for (int64_t j = 0; j < tb->n_P; ++j)
      weigh(K, tb->P + j, tb->n_P, s1, n_state, rows + j * n_state);
    return DL_OK;
  }
  const int64_t width = s1 + tb->n_extra;
  const int status = dl_stages(md, tb->A_extra, width, tb->C_extra, s1, s1, width, t_old, h,
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

static int project(dl_model *md, const dl_run *run, double t, double *y) {
  return dl_project(md, t, y, run->holonomic, run->max_newton, run->max_full,
                    run->position_tol, run->accept_tol);
}

/* One step from (st->t, y, K[0] = f(t, y)), finished as the Python loop finishes it:
 * the end projected into y_end, the outputs in (t_old, t_new] written after row
 * run->n_out (interpolated and projected; the one at t_new is the projected end). On
 * DL_OK the outputs are counted (n_out, next_eval) and the caller restarts from y_end;
 * on any other status run is as before and the caller restores st. */
static int finish_step(dl_model *md, const dl_tableau *tb, dl_stepper *st, dl_run *run,
                       const double *y, double *K, double *stage) {
  const int64_t n_state = 2 * md->n;
  const double t_old = st->t;
  int status = dl_rk_step(md, tb, st, y, K, run->y_new, stage);
  if (status != DL_OK) return status;
  const double t_new = st->t, d = st->direction;
  const int every_step = run->n_eval < 0;
  int64_t hi = run->next_eval;
  while (hi < run->n_eval && d * run->t_eval[hi] <= d * t_new) ++hi;
  const int64_t count = every_step ? 1 : hi - run->next_eval;
  if (run->n_out + count > run->capacity) return DL_OUTPUTS;
  memcpy(run->y_end, run->y_new, (size_t)n_state * sizeof(double));
  if ((status = project(md, run, t_new, run->y_end)) != DL_OK) return status;
  int made = 0;
  for (int64_t k = 0; k < count; ++k) {
    const double s = every_step ? t_new : run->t_eval[run->next_eval + k];
    double *row = run->y_out + (run->n_out + k) * n_state;
    run->t_out[run->n_out + k] = s;
    if (s == t_new) {
      memcpy(row, run->y_end, (size_t)n_state * sizeof(double));
      continue;
    }
    if (!made && (status = make_interpolant(md, tb, st, t_old, t_new - t_old, y, run->y_new, K,
                                            run->rows, stage)) != DL_OK)
      return status;
    made = 1;
    interpolate(tb, n_state, t_old, t_new - t_old, y, run->rows, s, row);
    if ((status = project(md, run, s, row)) != DL_OK) return status;
  }
  run->next_eval = hi;
  run->n_out += count;
  return DL_OK;
}

/* Steps from (st->t, y, K[0] = f(t, y)) as the Python loop takes them (finish_step),
 * until t_bound, the step or time budget, or a full output buffer. On return y,
 * K[0] and st hold the state after the last finished step; a non-OK status means
 * the next step could not be finished here (too small, a singular system, a failed
 * projection, more outputs than the buffer holds): the caller takes that step
 * itself, from this state, and st->nfev does not count the dropped attempt. */
int dl_rk_run(dl_model *md, const dl_tableau *tb, dl_stepper *st, dl_run *run, double *y,
              double *K, double *stage) {
  const int64_t n_state = 2 * md->n;
  const clock_t start = clock();
  run->n_steps = run->n_out = 0;
  while (st->direction * (st->t - st->t_bound) < 0 && run->n_steps < run->max_steps) {
    if (run->n_steps && (double)(clock() - start) > run->max_seconds * CLOCKS_PER_SEC) break;
    const dl_stepper before = *st;
    const int status = finish_step(md, tb, st, run, y, K, stage);
    if (status != DL_OK) {
      *st = before;
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
  }
  return DL_OK;
}
