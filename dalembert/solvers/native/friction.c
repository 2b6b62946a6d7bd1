/* The friction forces of a contact segment's sliding contacts, computed in C before
 * each evaluation (runtime.h's dl_friction, native/friction.py): the same solve as
 * contacts/friction.py's solve_sliding on the run's own model, and for the contacts
 * starting to slide from rest the same solve as its onset_friction, so that a sliding
 * segment's steps do not call Python at every evaluation. */
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

/* The onset's arrays for n_sliding contacts and n_tangent rows: the accelerations of
 * the tangent rows without friction and their responses (n_tangent and n_tangent^2),
 * each contact's plane (3 x 2), then, two per contact in its plane, the unknowns,
 * their accelerations, the point projected and the residual, and the same at a trial
 * step (8 x 2 n_sliding), the accelerations at a difference, the step and the scales
 * (3 x 2 n_sliding), the projection's 2 x 2 blocks and a trial's (2 x 4 n_sliding),
 * the Newton matrix and its right singular vectors ((2 n_sliding)^2 each), and a
 * trial's directions (n_tangent). */
DL_INLINE int64_t search_size(int64_t ns, int64_t nt) {
  return nt + nt * nt + 6 * ns + 22 * ns + 8 * ns + 8 * ns * ns + nt;
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
  w.group = w.search + search_size(ns, nt);
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

/* ---- The onset: the friction of the contacts starting to slide from rest ---- */

/* The onset's arrays (search_size's layout). */
typedef struct {
  double *a0, *T, *E, *x, *a, *z, *G, *xt, *at, *zt, *Gt, *shifted, *step, *rho, *P, *Pt;
  double *J, *V, *trial;
} search_work;

DL_INLINE search_work search_work_of(double *at, int64_t ns, int64_t nt) {
  search_work s;
  s.a0 = at;
  s.T = s.a0 + nt;
  s.E = s.T + nt * nt;
  s.x = s.E + 6 * ns;
  s.a = s.x + 2 * ns;
  s.z = s.a + 2 * ns;
  s.G = s.z + 2 * ns;
  s.xt = s.G + 2 * ns;
  s.at = s.xt + 2 * ns;
  s.zt = s.at + 2 * ns;
  s.Gt = s.zt + 2 * ns;
  s.shifted = s.Gt + 2 * ns;
  s.step = s.shifted + 2 * ns;
  s.rho = s.step + 2 * ns;
  s.P = s.rho + 2 * ns;
  s.Pt = s.P + 4 * ns;
  s.J = s.Pt + 4 * ns;
  s.V = s.J + 4 * ns * ns;
  s.trial = s.V + 4 * ns * ns;
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

/* The directions with the onset contacts' u = E x (x two per contact in its plane, the
 * others' as in w->direction) into s->trial, and the onset contacts' tangential
 * accelerations in their planes a = E^T (a0 + T (N u)) into a (N into w->N). 1 where
 * the normal forces are not found. */
static int onset_accelerations(const dl_friction *fr, const friction_work *w,
                               const search_work *s, const double *x, double *a) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns];
  memcpy(s->trial, w->direction, (size_t)nt * sizeof(double));
  for (int64_t k = 0, i = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    for (int64_t j = 0; j < fr->start[k + 1] - fr->start[k]; ++j)
      s->trial[fr->start[k] + j] = s->E[6 * k + 2 * j] * x[2 * i] +
                                   s->E[6 * k + 2 * j + 1] * x[2 * i + 1];
    ++i;
  }
  if (normal_forces(fr, w, s->trial, w->N)) return 1;
  for (int64_t k = 0, i = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    double a1 = 0.0, a2 = 0.0;
    for (int64_t r = fr->start[k]; r < fr->start[k + 1]; ++r) {
      double ar = s->a0[r];
      for (int64_t l = 0; l < ns; ++l)
        for (int64_t j = fr->start[l]; j < fr->start[l + 1]; ++j)
          ar += s->T[r * nt + j] * w->N[l] * s->trial[j];
      a1 += s->E[6 * k + 2 * (r - fr->start[k])] * ar;
      a2 += s->E[6 * k + 2 * (r - fr->start[k]) + 1] * ar;
    }
    a[2 * i] = a1, a[2 * i + 1] = a2;
    ++i;
  }
  return 0;
}

/* The natural residual at x, whose accelerations are a (p contacts, rho their scales):
 * the point projected onto each unit disk into z, G = x - z, and the projection's 2 x 2
 * Jacobian blocks into P; returns |G|'s largest entry, its 2-norm into *norm. */
static double natural_residual(int64_t p, const double *rho, const double *x, const double *a,
                               double *z, double *G, double *P, double *norm) {
  double worst = 0.0, squares = 0.0;
  for (int64_t c = 0; c < p; ++c) {
    const double z1 = x[2 * c] + rho[2 * c] * a[2 * c];
    const double z2 = x[2 * c + 1] + rho[2 * c + 1] * a[2 * c + 1];
    const double size = hypot(z1, z2);
    double *B = P + 4 * c;
    if (size > 1.0) {
      const double e1 = z1 / size, e2 = z2 / size;
      z[2 * c] = e1, z[2 * c + 1] = e2;
      B[0] = (1.0 - e1 * e1) / size, B[1] = B[2] = -e1 * e2 / size;
      B[3] = (1.0 - e2 * e2) / size;
    } else {
      z[2 * c] = z1, z[2 * c + 1] = z2;
      B[0] = B[3] = 1.0, B[1] = B[2] = 0.0;
    }
    for (int r = 0; r < 2; ++r) {
      G[2 * c + r] = x[2 * c + r] - z[2 * c + r];
      worst = fmax(worst, fabs(G[2 * c + r]));
      squares += G[2 * c + r] * G[2 * c + r];
    }
  }
  *norm = sqrt(squares);
  return worst;
}

/* Coulomb's law at the level of accelerations for the p onset contacts from their
 * directions in w->direction (friction.py's _coulomb_onset, its constants and steps):
 * semismooth Newton's method on G(x) = x - proj(x + rho a(x)), x each contact's u
 * in its plane, proj onto the unit disk, rho the inverse of the largest eigenvalue of
 * its block; the minimum-norm least-squares step, halved until |G| falls; where no
 * fraction does, a solution if |G| is within stalled, else a whole step all the same
 * (free_steps per solve), then the projection's own step (x to the point projected)
 * where that lowers |G|. 1 with the u found in w->direction, 0 where none is found
 * (w->direction as it was). */
static int coulomb_onset(const dl_friction *fr, const friction_work *w, const search_work *s,
                         int64_t p) {
  const int64_t ns = fr->n_sliding, nt = fr->start[ns], m = 2 * p;
  const double eps = 2.220446049250313e-16;
  for (int64_t k = 0, i = 0; k < ns; ++k) {  /* x: each one's u in its plane */
    if (!fr->onset[k]) continue;
    double u1 = 0.0, u2 = 0.0;
    for (int64_t j = 0; j < fr->start[k + 1] - fr->start[k]; ++j) {
      u1 += s->E[6 * k + 2 * j] * w->direction[fr->start[k] + j];
      u2 += s->E[6 * k + 2 * j + 1] * w->direction[fr->start[k] + j];
    }
    s->x[2 * i] = u1, s->x[2 * i + 1] = u2;
    ++i;
  }
  if (onset_accelerations(fr, w, s, s->x, s->a)) return 0;
  for (int64_t k = 0, i = 0; k < ns; ++k) {  /* rho: its block -N E^T T E */
    if (!fr->onset[k]) continue;
    double b[2][2];
    for (int c = 0; c < 2; ++c)
      for (int d = 0; d < 2; ++d) {
        double sum = 0.0;
        for (int64_t r = fr->start[k]; r < fr->start[k + 1]; ++r)
          for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j)
            sum += s->E[6 * k + 2 * (r - fr->start[k]) + c] * s->T[r * nt + j] *
                   s->E[6 * k + 2 * (j - fr->start[k]) + d];
        b[c][d] = -sum * w->N[k];
      }
    const double mean = 0.5 * (b[0][0] + b[1][1]), off = 0.5 * (b[0][1] + b[1][0]);
    const double radius = hypot(0.5 * (b[0][0] - b[1][1]), off);
    const double top = fmax(fabs(mean + radius), fabs(mean - radius));
    s->rho[2 * i] = s->rho[2 * i + 1] = top > 0.0 ? 1.0 / top : 1.0;
    ++i;
  }
  double norm, trial_norm;
  double worst = natural_residual(p, s->rho, s->x, s->a, s->z, s->G, s->P, &norm);
  int64_t free = fr->free_steps;
  for (int64_t it = 0; it < fr->iterations; ++it) {
    if (!(worst == worst)) return 0;
    if (worst <= fr->rounding * eps) {  /* its directions: the projected point's */
      if (onset_accelerations(fr, w, s, s->z, s->shifted)) return 0;
      memcpy(w->direction, s->trial, (size_t)nt * sizeof(double));
      return 1;
    }
    for (int64_t col = 0; col < m; ++col) {  /* J = I - P (I + rho da/dx), by columns */
      s->x[col] += fr->difference;
      const int failed = onset_accelerations(fr, w, s, s->x, s->shifted);
      s->x[col] -= fr->difference;
      if (failed) return 0;
      for (int64_t r = 0; r < m; ++r)  /* (I + rho da/dx)'s column col */
        s->shifted[r] = (r == col) + s->rho[r] * (s->shifted[r] - s->a[r]) / fr->difference;
      for (int64_t r = 0; r < m; ++r) {
        const int64_t c = r / 2, e = r % 2;
        const double *B = s->P + 4 * c;
        s->J[r * m + col] = (r == col) - B[2 * e] * s->shifted[2 * c] -
                            B[2 * e + 1] * s->shifted[2 * c + 1];
      }
    }
    for (int64_t r = 0; r < m; ++r) s->step[r] = -s->G[r];
    if (least_squares_small(s->J, s->V, s->shifted, s->step, m)) return 0;
    for (double fraction = 1.0;; fraction /= 2) {  /* halved until |G| falls */
      if (fraction < fr->smallest_step) {
        if (worst <= fr->stalled) {  /* its rounding, where it is that near */
          if (onset_accelerations(fr, w, s, s->z, s->shifted)) return 0;
          memcpy(w->direction, s->trial, (size_t)nt * sizeof(double));
          return 1;
        }
        /* else a whole step all the same (a few), then the projection's, x -> z */
        for (int64_t r = 0; r < m; ++r) s->xt[r] = free > 0 ? s->x[r] + s->step[r] : s->z[r];
        --free;
        if (onset_accelerations(fr, w, s, s->xt, s->at)) return 0;
        const double trial_worst =
            natural_residual(p, s->rho, s->xt, s->at, s->zt, s->Gt, s->Pt, &trial_norm);
        if (free < 0 && !(trial_norm < norm)) return 0;
        worst = trial_worst, norm = trial_norm;
        break;
      }
      for (int64_t r = 0; r < m; ++r) s->xt[r] = s->x[r] + fraction * s->step[r];
      if (onset_accelerations(fr, w, s, s->xt, s->at)) return 0;
      const double trial_worst =
          natural_residual(p, s->rho, s->xt, s->at, s->zt, s->Gt, s->Pt, &trial_norm);
      if (trial_norm < (1.0 - 1e-4 * fraction) * norm) {
        worst = trial_worst, norm = trial_norm;
        break;
      }
    }
    memcpy(s->x, s->xt, (size_t)m * sizeof(double));
    memcpy(s->a, s->at, (size_t)m * sizeof(double));
    memcpy(s->z, s->zt, (size_t)m * sizeof(double));
    memcpy(s->G, s->Gt, (size_t)m * sizeof(double));
    memcpy(s->P, s->Pt, (size_t)(2 * m) * sizeof(double));
  }
  return 0;
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

/* The friction of the contacts starting to slide from rest (fr->onset) into
 * w->direction: Coulomb's law at the level of accelerations (coulomb_onset), as
 * friction.py's onset_friction finds it, from the last found in the segment's steps
 * (last_direction), else from the start directions; where none is found, against the
 * sliding velocities (that start where one is 0). What is found is remembered
 * (remember 1) at the steps' evaluations, not where the screens or the outputs look
 * (dl_data's looking), and a stretch puts the memory back with a step it leaves to the
 * caller (keep_onset_memory), so that the steps are the same whether or not they are
 * looked at and wherever they run. */
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
  if (isfinite(fr->last_direction[fr->start[first]])) last_found(fr, w, 0);
  if (coulomb_onset(fr, w, &s, p)) {
    if (remember) last_found(fr, w, 1);
    return;
  }
  /* none found: friction against each one's sliding velocity, which cannot add energy
   * (kept as it started where that is 0) */
  for (int64_t k = 0; k < ns; ++k) {
    if (!fr->onset[k]) continue;
    double size = 0.0;
    for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j) {
      s.trial[j] = tangent_rate(fr, j, qd);
      size += s.trial[j] * s.trial[j];
    }
    size = sqrt(size);
    if (size > 0.0)
      for (int64_t j = fr->start[k]; j < fr->start[k + 1]; ++j)
        w->direction[j] = s.trial[j] / size;
  }
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
