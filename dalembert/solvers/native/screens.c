/* The screens of a stretch's events (runtime.h's dl_screens, native/screens.py): is a
 * step's end flagged, so that the stretch ends before the step and the caller takes it
 * with its event functions? A value at or above its margin proves that the event it
 * screens has not fired at the end; one below (or not finite) flags the step. */
#include "runtime.h"

/* `value >= margin` fails for NaN too: a value that is not finite flags the step. */
DL_INLINE int below(double value, double margin) { return !(value >= margin); }

/* Rows [start[i], start[i+1]) of count rows as dense rows of length n (row major) in A,
 * from the velocity values vel (entry: the value's place, col: its column). */
static void dense_rows(int64_t count, const int64_t *start, const int64_t *entry,
                       const int64_t *col, const double *vel, int64_t n, double *A) {
  memset(A, 0, (size_t)(count * n) * sizeof(double));
  for (int64_t i = 0; i < count; ++i)
    for (int64_t e = start[i]; e < start[i + 1]; ++e) A[i * n + col[e]] += vel[entry[e]];
}

/* The dropped rows of A (nr dense rows of length n, the nk kept ones first) as
 * combinations of the kept ones, a_d = C_d A_K: C_d = G^-1 A_K a_d with the Gram
 * matrix G = A_K A_K^T (factored in G). 1 (the step flagged) where G is not positive
 * definite or a dropped row lies off the kept rows' span by more than rtol times A's
 * largest entry (the dependency the run measured no longer holds). */
static int combinations(const double *A, int64_t nk, int64_t nr, int64_t n, double rtol,
                        double *G, double *C, double *r) {
  for (int64_t i = 0; i < nk; ++i)
    for (int64_t j = 0; j <= i; ++j) G[i * nk + j] = dot(A + i * n, A + j * n, n);
  if (nk && cholesky(G, nk) != DL_OK) return 1;
  const double scale = max_abs(A, nr * n);
  for (int64_t k = nk; k < nr; ++k) {
    const double *a = A + k * n;
    double *c = C + (k - nk) * nk;
    for (int64_t j = 0; j < nk; ++j) c[j] = dot(A + j * n, a, n);
    forward(G, nk, c);
    backward(G, nk, c);
    memcpy(r, a, (size_t)n * sizeof(double));
    for (int64_t j = 0; j < nk; ++j)
      for (int64_t x = 0; x < n; ++x) r[x] -= c[j] * A[j * n + x];
    if (!all_finite(c, nk) || !(max_abs(r, n) <= rtol * scale)) return 1;
  }
  return 0;
}

/* H = diag(w_K) + C_d^T diag(w_d) C_d (lower triangle; w NULL: unit weights), nk x nk,
 * with C_d the nr - nk rows of combinations' C. */
static void weighted_gram(const double *C, const double *w, int64_t nk, int64_t nr, double *H) {
  for (int64_t i = 0; i < nk; ++i)
    for (int64_t j = 0; j <= i; ++j) {
      double s = i == j ? (w ? w[i] : 1.0) : 0.0;
      for (int64_t k = nk; k < nr; ++k)
        s += (w ? w[k] : 1.0) * C[(k - nk) * nk + i] * C[(k - nk) * nk + j];
      H[i * nk + j] = s;
    }
}

/* The work arrays of a group of nr rows: A (nr n), G and C (nr^2 each), r (n), x and w
 * (nr each): native/screens.py's work size. */
typedef struct { double *A, *G, *C, *r, *x, *w; } group_work;

DL_INLINE group_work work_of(double *work, int64_t nr, int64_t n) {
  group_work g;
  g.A = work;
  g.G = g.A + nr * n;
  g.C = g.G + nr * nr;
  g.r = g.C + nr * nr;
  g.x = g.r + n;
  g.w = g.x + nr;
  return g;
}

/* The minimum-norm multipliers of a group of nr rows of a model of n coordinates and m
 * rows (row: the group's rows, its nk kept ones first; each read from the model's
 * velocity values vel by the entries [start[i], start[i+1]) of entry at columns col),
 * where the run dropped the others (its lambda 0 there): the ones with the same
 * A^T lambda, the projection onto the range of the group's A (friction.py's
 * _minimum_norm, the Python solve's lstsq). With A_R = C A_K (C the identity on the
 * kept rows) that range is C's, and with lambda 0 on the dropped rows C^T lambda_R =
 * lambda_K: out_R = C (I + C_d^T C_d)^-1 lambda_K. The other rows' are lambda's (their
 * rows share no coordinate with the group's). work: work_of's, for nr rows. 1 where the
 * dependency no longer holds (combinations). */
int group_minimum_norm(int64_t n, int64_t m, int64_t nr, int64_t nk, const int64_t *row,
                       const int64_t *start, const int64_t *entry, const int64_t *col,
                       const double *vel, double rtol, double *work, const double *lambda,
                       double *out) {
  group_work g = work_of(work, nr, n);
  if (out != lambda) memcpy(out, lambda, (size_t)m * sizeof(double));
  dense_rows(nr, start, entry, col, vel, n, g.A);
  if (combinations(g.A, nk, nr, n, rtol, g.G, g.C, g.r)) return 1;
  weighted_gram(g.C, NULL, nk, nr, g.G);
  if (cholesky(g.G, nk) != DL_OK) return 1;
  for (int64_t i = 0; i < nk; ++i) g.x[i] = lambda[row[i]];
  forward(g.G, nk, g.x);
  backward(g.G, nk, g.x);
  for (int64_t i = 0; i < nk; ++i) out[row[i]] = g.x[i];
  for (int64_t k = nk; k < nr; ++k) out[row[k]] = dot(g.C + (k - nk) * nk, g.x, nk);
  return 0;
}

/* The multipliers the events see, where the run dropped rows: the group's minimum-norm
 * ones. */
static int minimum_norm(const dl_model *md, const dl_screens *sc, const double *lambda,
                        double *out) {
  return group_minimum_norm(md->n, md->m, sc->n_group, sc->n_group_kept, sc->group_row,
                            sc->group_start, sc->group_entry, sc->group_col, sc->run_vel,
                            sc->dependent_rtol, sc->work, lambda, out);
}

/* The held contacts' friction shared in proportion to their normal forces, as
 * friction.py's held_forces gives it: the shares s minimizing sum s_i^2 / L_i (L_i the
 * normal force of tangent row i's contact) with the same A_T^T s = A_T^T lambda_T.
 * With A_T = C A_K (K its kept tangent rows): s = L C (C^T L C)^-1 C^T lambda_T, into
 * out's tangent rows (lambda: the multipliers the events see). 1 (the step flagged)
 * where a normal force is below margin (that contact's separating screen flags it
 * too) or C^T L C is not positive definite. */
static int held_shares(const dl_model *md, const dl_screens *sc, const double *lambda,
                       double margin, double *out) {
  const int64_t n = md->n, nr = sc->n_held, nk = sc->n_held_kept;
  group_work g = work_of(sc->work, nr, n);
  dense_rows(nr, sc->held_start, sc->held_entry, sc->held_col, sc->run_vel, n, g.A);
  if (combinations(g.A, nk, nr, n, sc->dependent_rtol, g.G, g.C, g.r)) return 1;
  for (int64_t i = 0; i < nr; ++i)
    if (below(g.w[i] = lambda[sc->held_normal[i]], margin)) return 1;
  weighted_gram(g.C, g.w, nk, nr, g.G);
  if (cholesky(g.G, nk) != DL_OK) return 1;
  for (int64_t i = 0; i < nk; ++i) {  /* C^T lambda_T */
    double s = lambda[sc->held_row[i]];
    for (int64_t k = nk; k < nr; ++k) s += g.C[(k - nk) * nk + i] * lambda[sc->held_row[k]];
    g.x[i] = s;
  }
  forward(g.G, nk, g.x);
  backward(g.G, nk, g.x);
  for (int64_t i = 0; i < nk; ++i) out[sc->held_row[i]] = g.w[i] * g.x[i];
  for (int64_t k = nk; k < nr; ++k)
    out[sc->held_row[k]] = g.w[k] * dot(g.C + (k - nk) * nk, g.x, nk);
  return 0;
}

int screened(const dl_model *md, dl_data *d, const dl_screens *sc, double t, const double *y,
             const double *lambda) {
  const int64_t n = md->n;
  const double *q = y, *qd = y + n;
  if (sc->n_position) {
    const double margin = sc->margin * (1.0 + max_abs(q, n));
    eval_static(&sc->position, t, q, sc->p, sc->psi);
    for (int64_t k = 0; k < sc->n_position; ++k)
      if (below(sc->psi[sc->pos_at[k]] - sc->pos_floor[k], margin)) return 1;
  }
  if (sc->n_rate) {
    const double margin = sc->margin * (1.0 + max_abs(qd, n));
    eval_static(&sc->velocity, t, q, sc->p, sc->vel);
    for (int64_t k = 0; k < sc->n_rate; ++k) {
      double value = 0.0;
      for (int64_t e = sc->rate_start[k]; e < sc->rate_start[k + 1]; ++e) {
        const int64_t col = sc->rate_col[e];
        value += sc->rate_weight[e] * sc->vel[sc->rate_value[e]] * (col >= 0 ? qd[col] : 1.0);
      }
      if (below(value - sc->rate_floor[k], margin)) return 1;
    }
  }
  if (!sc->n_force && !sc->n_cone) return 0;
  if (!lambda) {  /* the multipliers at the end: one more solve */
    d->looking = 1;
    const int status = dl_rhs(md, d, t, y, sc->ydot, sc->lambda);
    d->looking = 0;
    if (status != DL_OK) return 1;
    lambda = sc->lambda;
  }
  if (sc->n_group) {  /* dependent rows: the multipliers the events see */
    eval_static(&sc->run_velocity, t, q, d->p, sc->run_vel);
    if (minimum_norm(md, sc, lambda, sc->spread)) return 1;
    lambda = sc->spread;
  }
  const double margin = sc->force_rtol * (1.0 + max_abs(lambda, md->m));
  for (int64_t k = 0; k < sc->n_force; ++k)
    if (below(lambda[sc->force_row[k]], margin)) return 1;
  const double *friction = lambda;  /* the held contacts' tangential forces */
  if (sc->n_held && sc->n_cone) {
    double *shared = sc->spread + md->m;
    memcpy(shared, lambda, (size_t)md->m * sizeof(double));
    if (held_shares(md, sc, lambda, margin, shared)) return 1;
    friction = shared;
  }
  for (int64_t k = 0; k < sc->n_cone; ++k) {
    double tangential = 0.0;
    for (int64_t j = sc->cone_start[k]; j < sc->cone_start[k + 1]; ++j)
      tangential += friction[sc->cone_tangent[j]] * friction[sc->cone_tangent[j]];
    if (below(sc->cone_mu[k] * lambda[sc->cone_normal[k]] - sqrt(tangential), margin))
      return 1;
  }
  return 0;
}
