/* The friction forces of a contact segment's sliding contacts, computed in C before
 * each evaluation (runtime.h's dl_friction, native/friction.py): the same solve as
 * contacts/friction.py's solve_sliding on the run's own model, and for the contacts
 * starting to slide from rest the same search for their directions as its
 * consistent_directions, so that a sliding segment's steps do not call Python at every
 * evaluation. */
#include "runtime.h"

/* The work arrays (native/friction.py's work size): the directions (n_tangent), the
 * accelerations without friction (n), the responses to each tangent row's friction per
 * unit normal force (n_tangent x n) and their normal multipliers (n_tangent x
 * n_sliding), a force and a zero row vector (n, m), two multiplier vectors (m each),
 * R and N (n_sliding^2 + n_sliding), the onset's search (see search_work), then the
 * group's (screens.c's work_of). */
typedef struct {
  double *direction, *qdd0, *X, *RN, *force, *zeros, *lam0, *lam, *R, *N, *search, *group;
} friction_work;

/* The onset search's arrays for n_sliding contacts and n_tangent rows: the
 * accelerations of the tangent rows without friction and their responses (n_tangent
 * and n_tangent^2), each contact's plane (3 x 2), angles, residuals across and along,
 * a shifted residual, the Newton matrix and its right singular vectors (n_sliding
 * each, and twice n_sliding^2), a trial's directions (n_tangent), and the whole turn's
 * samples of the residual across (2 samples + 1). */
DL_INLINE int64_t search_size(int64_t ns, int64_t nt, int64_t samples) {
  return nt + nt * nt + 12 * ns + 2 * ns * ns + nt + 2 * samples + 1;
}

DL_INLINE friction_work friction_work_of(const dl_friction *fr, int64_t n, int64_t m) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns];
  friction_work w;
  w.direction = fr->work;
  w.qdd0 = w.direction + nt;
  w.X = w.qdd0 + n;
  w.RN = w.X + nt * n;
  w.force = w.RN + nt * ns;
  w.zeros = w.force + n;
  w.lam0 = w.zeros + m;
  w.lam = w.lam0 + m;
  w.R = w.lam + m;
  w.N = w.R + ns * ns;
  w.search = w.N + ns;
  w.group = w.search + search_size(ns, nt, fr->samples);
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

/* Tangent row j's A times x (its b left out). */
DL_INLINE double tangent_times(const dl_friction *fr, int64_t j, const double *x) {
  double s = 0.0;
  for (int64_t e = fr->term_start[j]; e < fr->term_start[j + 1]; ++e)
    if (fr->term_col[e] >= 0) s += fr->vel[fr->term_value[e]] * x[fr->term_col[e]];
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

/* The Jacobi rotation (c, s) that zeroes the off-diagonal entry apq of the symmetric
 * 2 x 2 [[app, apq], [apq, aqq]] (apq not 0): p' = c p - s q, q' = s p + c q, the
 * smaller angle (Golub and Van Loan's symmetric Schur decomposition). */
static void jacobi_rotation(double app, double aqq, double apq, double *c, double *s) {
  const double theta = (aqq - app) / (2.0 * apq);
  const double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
  *c = 1.0 / sqrt(t * t + 1.0);
  *s = t * *c;
}

/* x = the minimum-norm least-squares solution of A x = b for a small dense A (n x n, row
 * major; overwritten with A V), as numpy's lstsq with its default cut-off (singular
 * values below n eps times the largest taken as 0): A's singular value decomposition
 * by one-sided Jacobi rotations of its columns (V n x n, their product; coefficient:
 * n). 1 where the solution is not finite. */
static int least_squares_small(double *A, double *V, double *coefficient, double *b,
                               int64_t n) {
  const double eps = 2.220446049250313e-16;
  for (int64_t i = 0; i < n * n; ++i) V[i] = (i % (n + 1)) == 0 ? 1.0 : 0.0;
  for (int sweep = 0; sweep < 60; ++sweep) {
    int rotated = 0;
    for (int64_t i = 0; i < n - 1; ++i)
      for (int64_t j = i + 1; j < n; ++j) {
        double alpha = 0.0, beta = 0.0, gamma = 0.0;
        for (int64_t r = 0; r < n; ++r) {
          alpha += A[r * n + i] * A[r * n + i];
          beta += A[r * n + j] * A[r * n + j];
          gamma += A[r * n + i] * A[r * n + j];
        }
        if (!(fabs(gamma) > eps * sqrt(alpha * beta))) continue;
        rotated = 1;
        double c, s;
        jacobi_rotation(alpha, beta, gamma, &c, &s);
        for (int64_t r = 0; r < n; ++r) {
          const double ai = A[r * n + i], aj = A[r * n + j];
          A[r * n + i] = c * ai - s * aj;
          A[r * n + j] = s * ai + c * aj;
          const double vi = V[r * n + i], vj = V[r * n + j];
          V[r * n + i] = c * vi - s * vj;
          V[r * n + j] = s * vi + c * vj;
        }
      }
    if (!rotated) break;
  }
  /* A V = U Sigma: column k of A is sigma_k u_k; x = sum_k (u_k . b / sigma_k) v_k */
  double largest = 0.0;  /* sigma_k^2 into coefficient first */
  for (int64_t k = 0; k < n; ++k) {
    coefficient[k] = 0.0;
    for (int64_t r = 0; r < n; ++r) coefficient[k] += A[r * n + k] * A[r * n + k];
    largest = fmax(largest, coefficient[k]);
  }
  const double cut = (double)n * eps * sqrt(largest);
  for (int64_t k = 0; k < n; ++k) {
    double along = 0.0;
    for (int64_t r = 0; r < n; ++r) along += A[r * n + k] * b[r];
    coefficient[k] = sqrt(coefficient[k]) > cut ? along / coefficient[k] : 0.0;
  }
  for (int64_t r = 0; r < n; ++r) {
    b[r] = 0.0;
    for (int64_t k = 0; k < n; ++k) b[r] += coefficient[k] * V[r * n + k];
  }
  return !all_finite(b, n);
}

/* The contacts' normal forces N with the directions d (by tangent row): (I - R) N =
 * N_0, R's column k the normal multipliers of contact k's friction per unit normal
 * force, sum over its rows j of d_j RN[j]. 1 where the system is singular. */
static int normal_forces(const dl_friction *fr, const friction_work *w, const double *d,
                         double *N) {
  const int64_t ns = fr->n_sliding;
  for (int64_t i = 0; i < ns; ++i) {
    N[i] = w->lam0[fr->normal[i]];
    for (int64_t k = 0; k < ns; ++k) {
      double r = 0.0;
      for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) r += d[j] * w->RN[j * ns + i];
      w->R[i * ns + k] = (i == k) - r;
    }
  }
  return solve_small(w->R, N, ns);
}

/* ---- The onset: the directions of the contacts starting to slide from rest ---- */

/* The onset search's arrays (search_size's layout). */
typedef struct {
  double *a0, *T, *E, *angle, *across, *along, *shifted, *unused, *step, *J, *V, *trial;
  double *sampled;
} search_work;

DL_INLINE search_work search_work_of(double *at, int64_t ns, int64_t nt) {
  search_work s;
  s.a0 = at;
  s.T = s.a0 + nt;
  s.E = s.T + nt * nt;
  s.angle = s.E + 6 * ns;
  s.across = s.angle + ns;
  s.along = s.across + ns;
  s.shifted = s.along + ns;
  s.unused = s.shifted + ns;
  s.step = s.unused + ns;
  s.J = s.step + ns;
  s.V = s.J + ns * ns;
  s.trial = s.V + ns * ns;
  s.sampled = s.trial + nt;
  return s;
}

/* Contact k's plane (3 x 2, row major, its nj rows): the identity for two sliding
 * velocities; for three, an orthonormal basis of the span of their rows of A (the
 * leading eigenvectors of their Gram matrix, Jacobi's rotations), 1 where they are
 * not of rank 2 (friction.py's sliding_plane: no search then). */
static int sliding_plane(const dl_friction *fr, int64_t k, double *E) {
  const int64_t j0 = fr->start[k], nj = fr->start[k + 1] - j0;
  if (nj == 2) {
    E[0] = 1.0, E[1] = 0.0, E[2] = 0.0, E[3] = 1.0;
    return 0;
  }
  if (nj != 3) return 1;
  double G[3][3], V[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int64_t a = 0; a < 3; ++a)
    for (int64_t b = 0; b < 3; ++b) {
      double s = 0.0;  /* row a . row b over their common columns */
      for (int64_t e = fr->term_start[j0 + a]; e < fr->term_start[j0 + a + 1]; ++e) {
        if (fr->term_col[e] < 0) continue;
        for (int64_t f = fr->term_start[j0 + b]; f < fr->term_start[j0 + b + 1]; ++f)
          if (fr->term_col[f] == fr->term_col[e])
            s += fr->vel[fr->term_value[e]] * fr->vel[fr->term_value[f]];
      }
      G[a][b] = s;
    }
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = G[0][1] * G[0][1] + G[0][2] * G[0][2] + G[1][2] * G[1][2];
    const double diag = G[0][0] * G[0][0] + G[1][1] * G[1][1] + G[2][2] * G[2][2];
    if (!(off > 1e-32 * diag)) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (G[p][q] == 0.0) continue;
        double c, s;
        jacobi_rotation(G[p][p], G[q][q], G[p][q], &c, &s);
        for (int r = 0; r < 3; ++r) {  /* G <- G J */
          const double gp = G[r][p], gq = G[r][q];
          G[r][p] = c * gp - s * gq;
          G[r][q] = s * gp + c * gq;
        }
        for (int r = 0; r < 3; ++r) {  /* G <- J^T G */
          const double gp = G[p][r], gq = G[q][r];
          G[p][r] = c * gp - s * gq;
          G[q][r] = s * gp + c * gq;
        }
        for (int r = 0; r < 3; ++r) {  /* V <- V J */
          const double vp = V[r][p], vq = V[r][q];
          V[r][p] = c * vp - s * vq;
          V[r][q] = s * vp + c * vq;
        }
      }
  }
  int order[3] = {0, 1, 2};  /* eigenvalues, largest first */
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (G[order[b]][order[b]] > G[order[a]][order[a]]) {
        const int s = order[a];
        order[a] = order[b];
        order[b] = s;
      }
  /* rank 2, on the Gram matrix's eigenvalues (the squares of the rows' singular
   * values, whose rounding is eps times the largest: the test is on them, not on
   * their roots) */
  const double e0 = G[order[0]][order[0]], e1 = G[order[1]][order[1]];
  if (!(e1 > fr->dependent_rtol * e0) || G[order[2]][order[2]] > fr->dependent_rtol * e0)
    return 1;
  for (int r = 0; r < 3; ++r) {
    E[2 * r] = V[r][order[0]];
    E[2 * r + 1] = V[r][order[1]];
  }
  return 0;
}

/* The residuals of the onset contacts' angles: with their directions E u(angle) (the
 * others' as in d), the accelerations of their tangent rows a = a0 + T (N d) (N by
 * contact, d by row), across: cos a_2 - sin a_1 and along: cos a_1 + sin a_2 in their
 * planes (friction.py's consistent_directions). 1 where the normal forces are not
 * found. */
static int onset_residuals(const dl_friction *fr, const friction_work *w, const search_work *s,
                           const double *angle, double *across, double *along) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns];
  memcpy(s->trial, w->direction, (size_t)nt * sizeof(double));
  for (int64_t k = 0, i = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    const double c = cos(angle[i]), sn = sin(angle[i]);
    for (int64_t j = 0; j < fr->start[k + 1] - fr->start[k]; ++j)
      s->trial[fr->start[k] + j] = s->E[6 * k + 2 * j] * c + s->E[6 * k + 2 * j + 1] * sn;
    ++i;
  }
  if (normal_forces(fr, w, s->trial, w->N)) return 1;
  for (int64_t k = 0, i = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    double a1 = 0.0, a2 = 0.0;
    for (int64_t r = fr->start[k]; r < fr->start[k + 1]; ++r) {
      double a = s->a0[r];
      for (int64_t l = 0; l < ns; ++l)
        for (int64_t j = fr->start[l]; j < fr->start[l + 1]; ++j)
          a += s->T[r * nt + j] * w->N[l] * s->trial[j];
      a1 += s->E[6 * k + 2 * (r - fr->start[k])] * a;
      a2 += s->E[6 * k + 2 * (r - fr->start[k]) + 1] * a;
    }
    const double c = cos(angle[i]), sn = sin(angle[i]);
    across[i] = c * a2 - sn * a1;
    along[i] = c * a1 + sn * a2;
    ++i;
  }
  return 0;
}

/* Newton's method on the onset contacts' p angles from s->angle, as
 * consistent_directions takes it (its difference step, least-squares step, largest
 * turn, iterations and acceptance): 1 with their directions in w->direction, 0 where
 * it finds none near. */
static int newton_angles(const dl_friction *fr, const friction_work *w, const search_work *s,
                         int64_t p) {
  const int64_t ns = fr->n_sliding;
  const double eps = 2.220446049250313e-16;
  for (int it = 0; it < fr->iterations; ++it) {
    if (onset_residuals(fr, w, s, s->angle, s->across, s->along)) return 0;
    for (int64_t c = 0; c < p; ++c) {  /* J's column c by a forward difference */
      s->angle[c] += fr->difference;
      const int failed = onset_residuals(fr, w, s, s->angle, s->shifted, s->unused);
      s->angle[c] -= fr->difference;
      if (failed) return 0;
      for (int64_t r = 0; r < p; ++r)
        s->J[r * p + c] = (s->shifted[r] - s->across[r]) / fr->difference;
    }
    /* its friction does not turn its acceleration (other held rows fix its contact
     * point): no direction to seek, any root would be rounding's */
    const double scale = 1.0 + max_abs(s->across, p) + max_abs(s->along, p);
    if (!(max_abs(s->J, p * p) > fr->touch_rtol * scale)) return 0;
    for (int64_t r = 0; r < p; ++r) s->step[r] = -s->across[r];
    if (least_squares_small(s->J, s->V, s->shifted, s->step, p) ||
        !(max_abs(s->step, p) <= fr->turn))
      return 0;
    for (int64_t r = 0; r < p; ++r) s->angle[r] += s->step[r];
    if (max_abs(s->step, p) <= 4 * eps * (1.0 + max_abs(s->angle, p))) {
      const double floor = -fr->touch_rtol * (1.0 + max_abs(s->along, p));
      for (int64_t r = 0; r < p; ++r)
        if (!(s->along[r] >= floor)) return 0;
      for (int64_t k = 0, i = 0; k < ns; ++k) {
        if (!fr->onset[k]) continue;
        const double c = cos(s->angle[i]), sn = sin(s->angle[i]);
        for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) {
          const double *e = s->E + 6 * k + 2 * (j - fr->start[k]);
          w->direction[j] = e[0] * c + e[1] * sn;
        }
        ++i;
      }
      return 1;
    }
  }
  return 0;
}

/* Each onset contact's angle in its plane of its part of v (by tangent row) into
 * s->angle; 0 where one of them is 0 in the plane. */
static int angles_of(const dl_friction *fr, const search_work *s, const double *v) {
  for (int64_t k = 0, i = 0; k < fr->n_sliding; ++k) {
    if (!fr->onset[k]) continue;
    double u1 = 0.0, u2 = 0.0;
    for (int64_t j = 0; j < fr->start[k + 1] - fr->start[k]; ++j) {
      u1 += s->E[6 * k + 2 * j] * v[fr->start[k] + j];
      u2 += s->E[6 * k + 2 * j + 1] * v[fr->start[k] + j];
    }
    if (u1 == 0.0 && u2 == 0.0) return 0;
    s->angle[i++] = atan2(u2, u1);
  }
  return 1;
}

/* One onset contact's residuals at angle a: across (returned) and, in along, along. */
static double across_at(const dl_friction *fr, const friction_work *w, const search_work *s,
                        double a, double *along) {
  s->angle[0] = a;
  if (onset_residuals(fr, w, s, s->angle, s->across, s->along)) return NAN;
  *along = s->along[0];
  return s->across[0];
}

/* A single onset contact's direction by the whole turn's search of friction.py's
 * slip_direction, where Newton's method found none: the angle sampled at samples
 * points a half turn around the start one, each change of sign of the residual
 * across refined (bisection to rounding), the roots along which it accelerates kept,
 * the one nearest the start taken. 1 with its direction in w->direction, 0 where
 * there is none or its friction does not move it (every residual alike). */
static int whole_turn(const dl_friction *fr, const friction_work *w, const search_work *s,
                      int64_t k, double start) {
  const int64_t m = 2 * fr->samples;
  const double pi = 3.141592653589793;
  double previous = 0.0, along = 0.0, lowest = INFINITY, highest = -INFINITY, size = 0.0;
  double best = NAN, a_previous = 0.0;
  for (int64_t i = 0; i <= m; ++i) {  /* the samples, and the accelerations' scale */
    const double a = start - pi + 2.0 * pi * (double)i / (double)m;
    const double x = s->sampled[i] = across_at(fr, w, s, a, &along);
    if (!isfinite(x)) return 0;
    size = fmax(size, hypot(x, along));
    lowest = fmin(lowest, x);
    highest = fmax(highest, x);
  }
  const double scale = 1.0 + size, touch = fr->touch_rtol * scale;
  if (highest - lowest <= touch) return 0;  /* its friction does not move it */
  for (int64_t i = 0; i <= m; ++i) {
    const double a = start - pi + 2.0 * pi * (double)i / (double)m, x = s->sampled[i];
    if (i > 0 && (previous == 0.0 || previous * x < 0.0)) {
      double lo = a_previous, hi = a, f_lo = previous, root = a_previous;
      if (previous != 0.0) {
        for (int it = 0; it < 200 && hi - lo > 4e-16 * (1.0 + fabs(hi)); ++it) {
          const double mid = 0.5 * (lo + hi), f_mid = across_at(fr, w, s, mid, &along);
          if ((f_mid < 0.0) == (f_lo < 0.0)) lo = mid, f_lo = f_mid; else hi = mid;
        }
        root = 0.5 * (lo + hi);
      }
      across_at(fr, w, s, root, &along);
      if (along >= -touch && (isnan(best) || fabs(root - start) < fabs(best - start))) best = root;
    }
    previous = x;
    a_previous = a;
  }
  if (isnan(best)) return 0;
  const double c = cos(best), sn = sin(best);
  for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) {
    const double *e = s->E + 6 * k + 2 * (j - fr->start[k]);
    w->direction[j] = e[0] * c + e[1] * sn;
  }
  return 1;
}

/* The onset contacts' directions copied from (into w->direction) or to (remember 1,
 * from w->direction) the last found. */
static void last_found(const dl_friction *fr, const friction_work *w, int remember) {
  for (int64_t k = 0; k < fr->n_sliding; ++k) {
    if (!fr->onset[k]) continue;
    double *last = fr->last_direction + fr->start[k], *d = w->direction + fr->start[k];
    const size_t size = (size_t)(fr->start[k + 1] - fr->start[k]) * sizeof(double);
    if (remember) memcpy(last, d, size); else memcpy(d, last, size);
  }
}

/* The onset contacts' directions (into w->direction): the directions their contact
 * points accelerate in, sought by Newton's method (newton_angles) from their sliding
 * velocities' where these are above the rest speed (the slow manifold the motion
 * follows), else from their start directions; then from the start directions; for a
 * single contact, then around the whole turn; several contacts all moving then from
 * the last directions found in the segment's steps, kept themselves where that finds
 * none either; else the start ones are kept.
 *
 * The last found only after the others: the forces are a function of the state alone
 * wherever those find the directions. They do not where a body's contacts all slide
 * with no acceleration, its load within what their friction holds (after its corners
 * slipped one by one, creeping at below the onset's speed): their directions then
 * form a family, each root's neighbours roots too, which the growing load shrinks to
 * the one where the body breaks loose, and only the last found follow it there (the
 * Python side always starts from them). What is found is remembered (remember 1) at
 * the steps' evaluations, not where the screens or the outputs look (dl_data's
 * looking), and a stretch puts the memory back with a step it leaves to the caller
 * (keep_onset_memory), so that the steps are the same whether or not they are looked
 * at and wherever they run. */
static void onset_directions(const dl_model *md, const dl_friction *fr,
                             const friction_work *w, double t, const double *q,
                             const double *qd, int remember) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns], n = md->n;
  search_work s = search_work_of(w->search, ns, nt);
  int64_t p = 0, first = -1;
  for (int64_t k = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    if (sliding_plane(fr, k, s.E + 6 * k)) return;  /* no search: the start kept */
    if (first < 0) first = k;
    ++p;
  }
  /* the tangent rows' accelerations: without friction, and per unit of each row's */
  eval_state(&fr->kkt, t, q, qd, fr->p, fr->kkt_values);
  for (int64_t r = 0; r < nt; ++r) {
    s.a0[r] = tangent_times(fr, r, w->qdd0) - fr->kkt_values[fr->c_at + fr->tangent_row[r]];
    for (int64_t j = 0; j < nt; ++j) s.T[r * nt + j] = tangent_times(fr, r, w->X + j * n);
  }
  double *guess = s.trial;  /* (free until the next residual) */
  const double rest = fr->touch_rtol * (1.0 + max_abs(qd, n));  /* friction_at's speed */
  int moving = 1;  /* every onset contact sliding faster than that */
  for (int64_t k = 0; k < ns; ++k) {  /* each one's sliding velocity, its start if at rest */
    double size = 0.0;
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) {
      guess[j] = tangent_rate(fr, j, qd);
      size += guess[j] * guess[j];
    }
    if (!(sqrt(size) > rest)) {
      for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) guess[j] = fr->start_direction[j];
      if (fr->onset[k]) moving = 0;
    }
  }
  /* the last found, for several contacts all moving (at rest, the start directions
   * are the switch's own) */
  const int found_before = p > 1 && moving && isfinite(fr->last_direction[fr->start[first]]);
  if ((angles_of(fr, &s, guess) && newton_angles(fr, w, &s, p)) ||
      (angles_of(fr, &s, fr->start_direction) && newton_angles(fr, w, &s, p)) ||
      (found_before && angles_of(fr, &s, fr->last_direction) &&
       newton_angles(fr, w, &s, p))) {
    if (remember) last_found(fr, w, 1);
    return;
  }
  if (p == 1) {  /* one contact: the whole turn, as the Python side searches it */
    if (angles_of(fr, &s, fr->start_direction)) whole_turn(fr, w, &s, first, s.angle[0]);
    return;
  }
  if (found_before) last_found(fr, w, 0);
}

/* The onset search's last directions found kept at a stretch's step's start (restore
 * 0), put back where the step is not finished there (1): the caller takes it again
 * from its start, as the Python loop would have (nothing without sliding friction). */
void keep_onset_memory(const dl_data *d, int restore) {
  const dl_friction *fr = d->friction;
  if (!fr) return;
  const int64_t nt = fr->start[fr->n_sliding];
  double *last = fr->last_direction, *kept = last + nt;
  memcpy(restore ? last : kept, restore ? kept : last, (size_t)nt * sizeof(double));
}

int load_friction(const dl_model *md, dl_data *d, double t, const double *q, const double *qd) {
  const dl_friction *fr = d->friction;
  const int64_t n = md->n, m = md->m, ns = fr->n_sliding, nt = fr->start[ns];
  friction_work w = friction_work_of(fr, n, m);
  int onset = 0;
  for (int64_t i = 0; i < fr->n_copy; ++i) fr->p[fr->copy_to[i]] = d->p[fr->copy_from[i]];
  for (int64_t j = 0; j < nt; ++j) d->p[fr->slot[j]] = 0.0;
  eval_static(&fr->velocity, t, q, fr->p, fr->vel);
  if (fr->n_group) eval_static(&fr->run_velocity, t, q, d->p, fr->run_vel);
  for (int64_t k = 0; k < ns; ++k) {
    if (fr->onset[k]) {  /* sought from its start direction */
      onset = 1;
      memcpy(w.direction + fr->start[k], fr->start_direction + fr->start[k],
             (size_t)(fr->start[k + 1] - fr->start[k]) * sizeof(double));
    } else {
      sliding_direction(fr, k, qd, w.direction + fr->start[k]);
    }
  }
  /* the solve without friction, which holds the factors for the responses */
  eval_state(&md->fn[DL_FN_KKT], t, q, qd, d->p, d->values);
  if (!md->kkt_in_layout) load_kkt(md, d);
  int status = dl_solve(md, d, w.qdd0, w.lam0);
  if (status != DL_OK) return status;
  if (spread(md, fr, w.group, w.lam0)) return DL_RANK_CHANGED;
  /* the response to each tangent row's friction per unit normal force, -mu A_t^T */
  for (int64_t k = 0; k < ns; ++k)
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) {
      memset(w.force, 0, (size_t)n * sizeof(double));
      for (int64_t e = fr->term_start[j]; e < fr->term_start[j + 1]; ++e)
        if (fr->term_col[e] >= 0) w.force[fr->term_col[e]] -= fr->mu[k] * fr->vel[fr->term_value[e]];
      kkt_solve_one(md, d, w.force, w.zeros, w.X + j * n, w.lam);
      if (spread(md, fr, w.group, w.lam)) return DL_RANK_CHANGED;
      for (int64_t i = 0; i < ns; ++i) w.RN[j * ns + i] = w.lam[fr->normal[i]];
    }
  if (onset) onset_directions(md, fr, &w, t, q, qd, !d->looking);
  if (normal_forces(fr, &w, w.direction, w.N)) return DL_SINGULAR_CONSTRAINTS;
  for (int64_t k = 0; k < ns; ++k)
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j)
      d->p[fr->slot[j]] = -fr->mu[k] * w.N[k] * w.direction[j];
  return DL_OK;
}
