/* Radau IIA (order 5) steps in C, on the KKT structure.
 *
 * The step is scipy.integrate.Radau's (Hairer and Wanner's RADAU5 as SciPy writes it:
 * the simplified Newton iteration in the transformed variables W = TI Z, the error
 * estimate filtered through the real system, the predictive step-size controller,
 * the Jacobian kept while the iteration converges fast and the factors while the
 * step size stays), its constants and tests the same, so that its steps are SciPy's to
 * rounding (tested against LinearizedRadau, SciPy's step on the same linear algebra).
 *
 * Its linear systems (MU / h I - J) x = b, MU real or complex, are solved as
 * (I - c J) x = c b with c = h / MU, and (I - c J) x = b reduces to one system of the
 * KKT matrix's size (solvers/newton.py derives it):
 *
 *   [ M + c r1_v + c^2 r1_q    -A^T ] [ w ]     [ -r1_q s - r1_v b_v ]
 *   [ A + c r2_v + c^2 r2_q      0  ] [ l ]  =  [ -r2_q s - r2_v b_v ],
 *
 * s = b_q + c b_v, x = [s + c^2 w, b_v + c w]. Its unknowns are ordered by
 * dl_newton.perm (reverse Cuthill-McKee, native/radau.py) so that its nonzeros lie in a
 * band, narrow for chains and trees, and it is factored by a band LU with partial
 * pivoting (LAPACK's dgbtf2, its storage): a step costs time linear in the mechanism.
 */
#include "runtime.h"
#include <complex.h>

/* ---- band LU with partial pivoting, real and complex ---------------------------- */
/* A(i, j) at ab[j * ldab + kv + i - j], kv = kl + ku, ldab = 2 kl + ku + 1: the kl rows
 * above the band hold U's fill-in. DL_OK, or DL_SINGULAR_CONSTRAINTS for a zero pivot. */
#define DL_BAND_LU(NAME, T, ABS)                                                          \
  static int NAME##_factor(T *ab, int64_t N, int64_t kl, int64_t ku, int64_t ldab,       \
                           int64_t *piv) {                                                \
    const int64_t kv = kl + ku;                                                           \
    int64_t ju = 0;                                                                       \
    for (int64_t j = 0; j < N; ++j) {                                                     \
      T *col = ab + j * ldab + kv; /* col[i]: A(j + i, j) */                              \
      const int64_t km = kl < N - 1 - j ? kl : N - 1 - j;                                 \
      int64_t jp = 0;                                                                     \
      double big = ABS(col[0]);                                                           \
      for (int64_t i = 1; i <= km; ++i)                                                   \
        if (ABS(col[i]) > big) big = ABS(col[i]), jp = i;                                 \
      piv[j] = j + jp;                                                                    \
      if (big == 0.0 || !isfinite(big)) return DL_SINGULAR_CONSTRAINTS;                  \
      const int64_t last = j + ku + jp < N - 1 ? j + ku + jp : N - 1;                     \
      if (last > ju) ju = last;                                                           \
      if (jp != 0) /* swap rows j and j + jp over columns j..ju */                        \
        for (int64_t c = j; c <= ju; ++c) {                                               \
          T *a = ab + c * ldab + kv + j - c, tmp = a[0];                                  \
          a[0] = a[jp];                                                                   \
          a[jp] = tmp;                                                                    \
        }                                                                                 \
      const T inv = 1.0 / col[0];                                                         \
      for (int64_t i = 1; i <= km; ++i) col[i] *= inv;                                    \
      for (int64_t c = j + 1; c <= ju; ++c) {                                             \
        T *a = ab + c * ldab + kv + j - c; /* a[i]: A(j + i, c) */                        \
        const T u = a[0];                                                                 \
        if (u != 0.0)                                                                     \
          for (int64_t i = 1; i <= km; ++i) a[i] -= col[i] * u;                           \
      }                                                                                   \
    }                                                                                     \
    return DL_OK;                                                                         \
  }                                                                                       \
  static void NAME##_solve(const T *ab, int64_t N, int64_t kl, int64_t ku, int64_t ldab,  \
                           const int64_t *piv, T *b) {                                    \
    const int64_t kv = kl + ku;                                                           \
    for (int64_t j = 0; j < N; ++j) {                                                     \
      const int64_t km = kl < N - 1 - j ? kl : N - 1 - j;                                 \
      if (piv[j] != j) {                                                                  \
        const T tmp = b[j];                                                               \
        b[j] = b[piv[j]];                                                                 \
        b[piv[j]] = tmp;                                                                  \
      }                                                                                   \
      const T *col = ab + j * ldab + kv, bj = b[j];                                       \
      for (int64_t i = 1; i <= km; ++i) b[j + i] -= col[i] * bj;                          \
    }                                                                                     \
    for (int64_t j = N - 1; j >= 0; --j) {                                                \
      const T *col = ab + j * ldab + kv; /* col[i - j]: U(i, j), i <= j */                \
      b[j] /= col[0];                                                                     \
      const T bj = b[j];                                                                  \
      const int64_t top = j - kv > 0 ? j - kv : 0;                                        \
      for (int64_t i = top; i < j; ++i) b[i] -= col[i - j] * bj;                          \
    }                                                                                     \
  }

static inline double abs_real(double x) { return fabs(x); }
static inline double abs_complex(double complex x) { return fabs(creal(x)) + fabs(cimag(x)); }
DL_BAND_LU(band_real, double, abs_real)
DL_BAND_LU(band_complex, double complex, abs_complex)

/* ---- the method's constants (scipy/integrate/_ivp/radau.py) ---------------------- */
#define S6 2.449489742783178098197284074705891391965947480656670128432692567
static const double RC[3] = {(4.0 - S6) / 10.0, (4.0 + S6) / 10.0, 1.0};
static const double RE[3] = {(-13.0 - 7.0 * S6) / 3.0, (-13.0 + 7.0 * S6) / 3.0, -1.0 / 3.0};
static const double RT[3][3] = {
    {0.09443876248897524, -0.14125529502095421, 0.03002919410514742},
    {0.25021312296533332, 0.20412935229379994, -0.38294211275726192},
    {1.0, 1.0, 0.0}};
static const double RTI[3][3] = {
    {4.17871859155190428, 0.32768282076106237, 0.52337644549944951},
    {-4.17871859155190428, -0.32768282076106237, 0.47662355450055044},
    {0.50287263494578682, -2.57192694985560522, 0.59603920482822492}};
static const double RP[3][3] = {
    {13.0 / 3.0 + 7.0 * S6 / 3.0, -23.0 / 3.0 - 22.0 * S6 / 3.0, 10.0 / 3.0 + 5.0 * S6},
    {13.0 / 3.0 - 7.0 * S6 / 3.0, -23.0 / 3.0 + 22.0 * S6 / 3.0, 10.0 / 3.0 - 5.0 * S6},
    {1.0 / 3.0, -8.0 / 3.0, 10.0 / 3.0}};
enum { NEWTON_MAXITER = 6 };
static const double RADAU_MIN_FACTOR = 0.2, RADAU_MAX_FACTOR = 10.0;

/* MU_REAL and MU_COMPLEX: the inverse eigenvalues of the method's matrix. */
static double mu_real(void) { return 3.0 + pow(3.0, 2.0 / 3.0) - pow(3.0, 1.0 / 3.0); }
static double complex mu_complex(void) {
  return (3.0 + 0.5 * (pow(3.0, 1.0 / 3.0) - pow(3.0, 2.0 / 3.0)))
         - 0.5 * _Complex_I * (pow(3.0, 5.0 / 6.0) + pow(3.0, 7.0 / 6.0));
}

/* ---- the linearization and its factors ----------------------------------------- */

/* The values the reduced matrix is made of, at (t, y): the KKT function's and the
 * residuals' Jacobians at the solution (qdd, lambda) there. */
static int linearize(const dl_model *md, dl_data *d, dl_radau *st, double t,
                     const double *y) {
  const int64_t n = md->n;
  double *ydot = st->work, *lambda = st->work + 2 * n;  /* 2 n + m of the work */
  int status = dl_rhs(md, d, t, y, ydot, lambda);
  if (status != DL_OK) return status;
  const double *kkt_args[] = {&t, y, y + n};
  if (dl_call(md, d, DL_FN_KKT, kkt_args, st->kkt) != DL_OK) return DL_SINGULAR_MASS;
  const double *jac_args[] = {&t, y, y + n, ydot + n, lambda};
  if (dl_call(md, d, DL_FN_RESIDUAL_JACOBIANS, jac_args, st->jac) != DL_OK)
    return DL_SINGULAR_MASS;
  st->njev++;
  st->jac_ready = 1;
  return DL_OK;
}

/* The band ab (real or complex) of I - c J's reduced matrix (see the top), from the
 * held values. */
#define ASSEMBLE(ab, nw, st, c)                                                           \
  do {                                                                                    \
    memset(ab, 0, (size_t)((nw)->ldab * (nw)->N) * sizeof(*(ab)));                        \
    for (int64_t k = 0; k < (nw)->n_fixed; ++k)                                           \
      (ab)[(nw)->fixed_dst[k]] += (nw)->fixed_sign[k] * (st)->kkt[(nw)->fixed_src[k]];    \
    for (int64_t k = 0; k < (nw)->n_v; ++k)                                               \
      (ab)[(nw)->v_dst[k]] += (c) * (st)->jac[(nw)->v_src[k]];                            \
    for (int64_t k = 0; k < (nw)->n_q; ++k)                                               \
      (ab)[(nw)->q_dst[k]] += (c) * (c) * (st)->jac[(nw)->q_src[k]];                      \
  } while (0)

/* The band of I - c J's reduced matrix (see the top), factored. */
static int factor_real(const dl_newton *nw, dl_radau *st, double c) {
  double *ab = st->lu_real;
  ASSEMBLE(ab, nw, st, c);
  st->nlu++;
  st->c_real = c;
  return band_real_factor(ab, nw->N, nw->kl, nw->ku, nw->ldab, st->piv_real);
}

static int factor_complex(const dl_newton *nw, dl_radau *st, double complex c) {
  double complex *ab = (double complex *)st->lu_complex;
  ASSEMBLE(ab, nw, st, c);
  st->nlu++;
  st->c_complex_re = creal(c);
  st->c_complex_im = cimag(c);
  return band_complex_factor(ab, nw->N, nw->kl, nw->ku, nw->ldab, st->piv_complex);
}

/* x = (I - c J)^-1 (c b), the solve of (MU / h I - J) x = b with the held real factors
 * (c = h / MU at their making), in place in b (2 n). */
static void solve_real(const dl_newton *nw, dl_radau *st, int64_t n, double *b) {
  const double c = st->c_real;
  double *s = st->work, *r = st->work + n, *bv = b + n;
  for (int64_t i = 0; i < 2 * n; ++i) b[i] *= c;
  for (int64_t i = 0; i < n; ++i) s[i] = b[i] + c * bv[i];
  double *rhs = st->work + n + nw->N;
  memset(rhs, 0, (size_t)nw->N * sizeof(double));
  for (int64_t k = 0; k < nw->n_q; ++k) rhs[nw->q_row[k]] -= st->jac[nw->q_src[k]] * s[nw->q_col[k]];
  for (int64_t k = 0; k < nw->n_v; ++k) rhs[nw->v_row[k]] -= st->jac[nw->v_src[k]] * bv[nw->v_col[k]];
  for (int64_t i = 0; i < nw->N; ++i) r[nw->perm[i]] = rhs[i];
  band_real_solve(st->lu_real, nw->N, nw->kl, nw->ku, nw->ldab, st->piv_real, r);
  for (int64_t i = 0; i < n; ++i) {
    const double w = r[nw->perm[i]];
    b[i] = s[i] + c * c * w;
    bv[i] += c * w;
  }
}

/* The same with the complex factors: b_re, b_im (2 n each) in place. */
static void solve_complex(const dl_newton *nw, dl_radau *st, int64_t n, double *b_re,
                          double *b_im) {
  const double complex c = st->c_complex_re + _Complex_I * st->c_complex_im;
  double complex *s = (double complex *)st->cwork, *bv = s + n, *r = bv + n, *rhs = r + nw->N;
  for (int64_t i = 0; i < n; ++i) {
    bv[i] = c * (b_re[n + i] + _Complex_I * b_im[n + i]);
    s[i] = c * (b_re[i] + _Complex_I * b_im[i]) + c * bv[i];
  }
  memset(rhs, 0, (size_t)nw->N * sizeof(double complex));
  for (int64_t k = 0; k < nw->n_q; ++k) rhs[nw->q_row[k]] -= st->jac[nw->q_src[k]] * s[nw->q_col[k]];
  for (int64_t k = 0; k < nw->n_v; ++k) rhs[nw->v_row[k]] -= st->jac[nw->v_src[k]] * bv[nw->v_col[k]];
  for (int64_t i = 0; i < nw->N; ++i) r[nw->perm[i]] = rhs[i];
  band_complex_solve((const double complex *)st->lu_complex, nw->N, nw->kl, nw->ku, nw->ldab,
                     st->piv_complex, r);
  for (int64_t i = 0; i < n; ++i) {
    const double complex w = r[nw->perm[i]], xq = s[i] + c * c * w, xv = bv[i] + c * w;
    b_re[i] = creal(xq);
    b_im[i] = cimag(xq);
    b_re[n + i] = creal(xv);
    b_im[n + i] = cimag(xv);
  }
}

/* ---- the step --------------------------------------------------------------------- */

/* SciPy's norm: root mean square. */
static double rms(const double *x, const double *scale, int64_t count, int64_t n_state) {
  double s = 0.0;
  for (int64_t i = 0; i < count; ++i) {
    const double a = x[i] / scale[i % n_state];
    s += a * a;
  }
  return sqrt(s / (double)count);
}

static double predict_factor(double h_abs, double h_abs_old, double error_norm,
                             double error_norm_old) {
  double multiplier = 1.0;
  if (!(error_norm_old < 0.0 || h_abs_old < 0.0 || error_norm == 0.0))
    multiplier = h_abs / h_abs_old * pow(error_norm_old / error_norm, 0.25);
  return (multiplier < 1.0 ? multiplier : 1.0) * pow(error_norm, -0.25);
}

/* The collocation system's simplified Newton iteration (SciPy's
 * solve_collocation_system). Z (3 x n_state) holds the guess on entry, the iterate on
 * return; *converged, *n_iter and *rate as SciPy's. */
static int collocation(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                       double t, const double *y, double h, const double *scale, double *Z,
                       int *converged, int64_t *n_iter, double *rate) {
  const int64_t n = md->n, ns = 2 * n;
  const double m_real = mu_real() / h;
  const double complex m_complex = mu_complex() / h;
  double *W = st->stage_work, *F = W + 3 * ns, *dW = F + 3 * ns, *stage = dW + 3 * ns;
  for (int64_t i = 0; i < ns; ++i)
    for (int64_t k = 0; k < 3; ++k)
      W[k * ns + i] = RTI[k][0] * Z[i] + RTI[k][1] * Z[ns + i] + RTI[k][2] * Z[2 * ns + i];
  double dW_norm_old = -1.0;
  *converged = 0;
  *rate = -1.0;
  int64_t k = 0;
  for (; k < NEWTON_MAXITER; ++k) {
    int finite = 1;
    for (int64_t j = 0; j < 3; ++j) {
      for (int64_t i = 0; i < ns; ++i) stage[i] = y[i] + Z[j * ns + i];
      st->nfev++;
      const int status = dl_rhs(md, d, t + RC[j] * h, stage, F + j * ns, NULL);
      if (status != DL_OK) return status;
      if (!all_finite(F + j * ns, ns)) finite = 0;
    }
    if (!finite) break;
    double *f_real = dW, *f_re = dW + ns, *f_im = dW + 2 * ns;
    for (int64_t i = 0; i < ns; ++i) {
      const double F0 = F[i], F1 = F[ns + i], F2 = F[2 * ns + i];
      f_real[i] = F0 * RTI[0][0] + F1 * RTI[0][1] + F2 * RTI[0][2] - m_real * W[i];
      const double complex fc = (F0 * RTI[1][0] + F1 * RTI[1][1] + F2 * RTI[1][2])
          + _Complex_I * (F0 * RTI[2][0] + F1 * RTI[2][1] + F2 * RTI[2][2])
          - m_complex * (W[ns + i] + _Complex_I * W[2 * ns + i]);
      f_re[i] = creal(fc);
      f_im[i] = cimag(fc);
    }
    solve_real(nw, st, n, f_real);
    solve_complex(nw, st, n, f_re, f_im);
    const double dW_norm = rms(dW, scale, 3 * ns, ns);
    if (dW_norm_old >= 0.0) *rate = dW_norm / dW_norm_old;
    if (*rate >= 0.0 && (*rate >= 1.0 ||
                         pow(*rate, (double)(NEWTON_MAXITER - k)) / (1.0 - *rate) * dW_norm >
                             st->newton_tol))
      break;
    for (int64_t i = 0; i < 3 * ns; ++i) W[i] += dW[i];
    for (int64_t i = 0; i < ns; ++i)
      for (int64_t j = 0; j < 3; ++j)
        Z[j * ns + i] = RT[j][0] * W[i] + RT[j][1] * W[ns + i] + RT[j][2] * W[2 * ns + i];
    if (dW_norm == 0.0 || (*rate >= 0.0 && *rate / (1.0 - *rate) * dW_norm < st->newton_tol)) {
      *converged = 1;
      break;
    }
    dW_norm_old = dW_norm;
  }
  *n_iter = (k < NEWTON_MAXITER ? k : NEWTON_MAXITER - 1) + 1;
  return DL_OK;
}

/* The last step's interpolant at t' (SciPy's RadauDenseOutput): y_old + Q [x, x^2, x^3]. */
static void interpolate_last(const dl_radau *st, int64_t ns, double t, double *out) {
  const double x = (t - st->sol_t_old) / st->sol_h, p[3] = {x, x * x, x * x * x};
  for (int64_t i = 0; i < ns; ++i)
    out[i] = st->sol_Q[i] * p[0] + st->sol_Q[ns + i] * p[1] + st->sol_Q[2 * ns + i] * p[2]
             + st->sol_y_old[i];
}

/* One accepted step of SciPy's Radau from (st->t, y, f): on DL_OK, y_new, f_new, Z and
 * st (t, t_old, h_abs, ..., the held Jacobian and factors, the interpolant) as
 * SciPy's _step_impl leaves the solver; DL_STEP_TOO_SMALL as its TOO_SMALL_STEP. */
int dl_radau_step(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                  const double *y, const double *f, double *y_new, double *f_new, double *Z) {
  const int64_t n = md->n, ns = 2 * n;
  const double t = st->t;
  if (!isfinite(t) || isnan(st->h_abs) || !all_finite(y, ns) || !all_finite(f, ns))
    return DL_NOT_FINITE;
  const double min_step = 10.0 * fabs(nextafter(t, st->direction * INFINITY) - t);
  double h_abs = st->h_abs, h_abs_old = st->h_abs_old, error_norm_old = st->error_norm_old;
  if (st->h_abs > st->max_step) h_abs = st->max_step, h_abs_old = error_norm_old = -1.0;
  else if (st->h_abs < min_step) h_abs = min_step, h_abs_old = error_norm_old = -1.0;
  if (!st->jac_ready) {  /* SciPy's Radau makes its Jacobian when it is made */
    const int status = linearize(md, d, st, t, y);
    if (status != DL_OK) return status;
    st->current_jac = 1;
  }
  /* the stage work after the iteration's 10 ns (see collocation) */
  double *scale = st->stage_work + 10 * ns, *error = scale + ns, *stage = error + ns,
         *ZE = stage + ns, *Z_try = ZE + ns;
  int rejected = 0, converged = 0;
  int64_t n_iter = 0;
  double rate = -1.0, error_norm = 0.0, h = 0.0, t_new = t, safety = 0.9;
  for (;;) {
    if (h_abs < min_step) return DL_STEP_TOO_SMALL;
    h = h_abs * st->direction;
    t_new = t + h;
    if (st->direction * (t_new - st->t_bound) > 0) t_new = st->t_bound;
    h = t_new - t;
    h_abs = fabs(h);
    double *guess = stage;
    for (int64_t j = 0; j < 3; ++j) {
      if (!st->has_sol) {
        memset(Z + j * ns, 0, (size_t)ns * sizeof(double));
        continue;
      }
      interpolate_last(st, ns, t + h * RC[j], guess);
      for (int64_t i = 0; i < ns; ++i) Z[j * ns + i] = guess[i] - y[i];
    }
    for (int64_t i = 0; i < ns; ++i) scale[i] = st->atol[i] + fabs(y[i]) * st->rtol;
    converged = 0;
    while (!converged) {
      int singular = 0;
      if (!st->lu_ready) {
        const double c = h / mu_real();
        const double complex cc = h / mu_complex();
        singular = factor_real(nw, st, c) != DL_OK || factor_complex(nw, st, cc) != DL_OK;
        st->lu_ready = !singular;
      }
      if (!singular) {
        memcpy(Z_try, Z, (size_t)(3 * ns) * sizeof(double));
        const int status = collocation(md, d, nw, st, t, y, h, scale, Z_try, &converged,
                                       &n_iter, &rate);
        if (status != DL_OK) return status;
        if (converged) memcpy(Z, Z_try, (size_t)(3 * ns) * sizeof(double));
      }
      if (!converged) {
        if (st->current_jac) break;
        const int status = linearize(md, d, st, t, y);
        if (status != DL_OK) return status;
        st->current_jac = 1;
        st->lu_ready = 0;
      }
    }
    if (!converged) {
      h_abs *= 0.5;
      st->lu_ready = 0;
      continue;
    }
    for (int64_t i = 0; i < ns; ++i) {
      y_new[i] = y[i] + Z[2 * ns + i];
      ZE[i] = (Z[i] * RE[0] + Z[ns + i] * RE[1] + Z[2 * ns + i] * RE[2]) / h;
      error[i] = f[i] + ZE[i];
    }
    solve_real(nw, st, n, error);
    for (int64_t i = 0; i < ns; ++i) {
      const double big = fabs(y[i]) > fabs(y_new[i]) ? fabs(y[i]) : fabs(y_new[i]);
      scale[i] = st->atol[i] + big * st->rtol;
    }
    error_norm = rms(error, scale, ns, ns);
    safety = 0.9 * (2.0 * NEWTON_MAXITER + 1.0) / (2.0 * NEWTON_MAXITER + (double)n_iter);
    if (rejected && error_norm > 1.0) {
      for (int64_t i = 0; i < ns; ++i) stage[i] = y[i] + error[i];
      st->nfev++;
      const int status = dl_rhs(md, d, t, stage, error, NULL);
      if (status != DL_OK) return status;
      for (int64_t i = 0; i < ns; ++i) error[i] += ZE[i];
      solve_real(nw, st, n, error);
      error_norm = rms(error, scale, ns, ns);
    }
    if (error_norm > 1.0) {
      const double factor = predict_factor(h_abs, h_abs_old, error_norm, error_norm_old);
      h_abs *= RADAU_MIN_FACTOR > safety * factor ? RADAU_MIN_FACTOR : safety * factor;
      st->lu_ready = 0;
      rejected = 1;
    } else {
      break;
    }
  }
  const int recompute_jac = n_iter > 2 && rate > 1e-3;
  double factor = predict_factor(h_abs, h_abs_old, error_norm, error_norm_old);
  factor = RADAU_MAX_FACTOR < safety * factor ? RADAU_MAX_FACTOR : safety * factor;
  if (!recompute_jac && factor < 1.2) factor = 1.0;
  else st->lu_ready = 0;
  st->nfev++;
  int status = dl_rhs(md, d, t_new, y_new, f_new, NULL);
  if (status != DL_OK) return status;
  if (recompute_jac) {
    if ((status = linearize(md, d, st, t_new, y_new)) != DL_OK) return status;
    st->current_jac = 1;
  } else {
    st->current_jac = 0;
  }
  st->h_abs_old = st->h_abs;
  st->error_norm_old = error_norm;
  st->h_abs = h_abs * factor;
  st->t_old = t;
  st->t = t_new;
  /* the interpolant, Q = Z^T P, kept for the next step's guess */
  for (int64_t i = 0; i < ns; ++i) {
    st->sol_y_old[i] = y[i];
    for (int64_t j = 0; j < 3; ++j)
      st->sol_Q[j * ns + i] = Z[i] * RP[0][j] + Z[ns + i] * RP[1][j] + Z[2 * ns + i] * RP[2][j];
  }
  st->sol_t_old = t;
  st->sol_h = t_new - t;
  st->has_sol = 1;
  return DL_OK;
}

/* ---- whole stretches: step, projection, outputs, restart ---------------------------- */

/* One step from (st->t, y, f) finished as the Python loop finishes it (integrate.py):
 * the end projected into run->y_end and f there into f_end (SciPy's restart; DL_EVENT
 * if a screen flags the end), the outputs in (t_old, t_new] written after row run->n_out (the step's interpolant,
 * projected; the one at t_new is the projected end). On DL_OK the outputs are counted;
 * on any other status nothing is, and the caller restores st's scalars. */
static int radau_finish(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                        dl_run *run, const double *y, const double *f, double *f_end,
                        double *Z) {
  const int64_t ns = 2 * md->n;
  int status = dl_radau_step(md, d, nw, st, y, f, run->y_new, run->rows, Z);
  if (status != DL_OK) return status;
  const double t_new = st->t;
  const int every_step = run->n_eval < 0;
  int64_t hi, count;
  if ((status = end_of_step(md, d, run, t_new, st->direction, &hi, &count)) != DL_OK)
    return status;
  const double conditioning = d->conditioning;
  st->nfev++;
  const dl_screens *sc = run->screens;
  double *lambda = sc && (sc->n_force || sc->n_cone) ? sc->lambda : NULL;
  if ((status = dl_rhs(md, d, t_new, run->y_end, f_end, lambda)) != DL_OK) return status;
  if (sc && screened(md, d, sc, t_new, run->y_end, lambda)) return DL_EVENT;
  for (int64_t k = 0; k < count; ++k) {
    const double s = every_step ? t_new : run->t_eval[run->next_eval + k];
    double *row = run->y_out + (run->n_out + k) * ns;
    run->t_out[run->n_out + k] = s;
    if (s == t_new) {
      memcpy(row, run->y_end, (size_t)ns * sizeof(double));
      continue;
    }
    interpolate_last(st, ns, s, row);
    if ((status = run_project(md, d, run, s, row)) != DL_OK) return status;
  }
  run->next_eval = hi;
  run->n_out += count;
  return conditioning < run->near2 ? DL_NEAR_SINGULAR : DL_OK;
}

/* Steps from (st->t, y, f = f(t, y)) as the Python loop takes them (radau_finish), until
 * t_bound, the step or time budget, or a full output buffer; as dl_rk_run (see it): on
 * return y, f and st hold the state after the last finished step, and a non-OK status
 * leaves the next step to the caller. The held Jacobian, factors and interpolant of a
 * step that could not be finished stay: they are as good a start for the caller's step
 * as the ones before (each is only the simplified Newton iteration's matrix or guess),
 * and the scalars that say what the factors are stay with them. */
int dl_radau_run(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                 dl_run *run, double *y, double *f, double *Z) {
  const int64_t ns = 2 * md->n;
  double *f_end = run->rows + ns;
  const double start = wall_seconds();
  run->n_steps = run->n_out = 0;
  if (!isfinite(st->t)) return DL_NOT_FINITE;
  while (st->direction * (st->t - st->t_bound) < 0 && run->n_steps < run->max_steps) {
    if (run->n_steps && wall_seconds() - start > run->max_seconds) break;
    const double t = st->t, h_abs = st->h_abs, h_abs_old = st->h_abs_old,
                 error_norm_old = st->error_norm_old, t_old = st->t_old;
    keep_onset_memory(d, 0);
    const int status = radau_finish(md, d, nw, st, run, y, f, f_end, Z);
    if (status != DL_OK && status != DL_NEAR_SINGULAR) {
      keep_onset_memory(d, 1);
      st->t = t, st->h_abs = h_abs, st->h_abs_old = h_abs_old;
      st->error_norm_old = error_norm_old, st->t_old = t_old;
      return status == DL_OUTPUTS && run->n_steps ? DL_OK : status;
    }
    run->t_old = t;
    ++run->n_steps;
    memcpy(y, run->y_end, (size_t)ns * sizeof(double));
    memcpy(f, f_end, (size_t)ns * sizeof(double));
    if (status == DL_NEAR_SINGULAR) return status;  /* the caller measures and decides */
  }
  return DL_OK;
}

/* the one translation unit goes on after this source: complex.h's short names end here */
#undef I
#undef complex
#undef ASSEMBLE
