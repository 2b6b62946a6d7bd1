/* The simulation loop of dalembert in C: declarations shared by its sources.
 *
 * The model's generated functions (KKT blocks, velocity constraint, position
 * constraint, ...: dl_model.fn, by the registry's places) are called through pointers;
 * everything else here is hand-written and model independent. See native/__init__.py
 * for the method and the tables. Every entry point takes the model (dl_model: constant,
 * read only, one for any number of runs on any threads) and one run's data (dl_data:
 * everything the call writes).
 * The sources, compiled together into one library (library.py):
 *   kkt.c          the KKT factorization (block Cholesky, Schur complement in band
 *                  LDL^T form) and its solves: the right-hand side's, and many
 *                  right-hand sides over any active rows (dl_kkt_factor, dl_kkt_solve)
 *   outputs.c      the trajectory's derived quantities at given states
 *   projection.c   projection of a state onto the constraints
 *   screens.c      the screens of a stretch's events
 *   friction.c     the friction forces of sliding contacts, before each evaluation
 *   runge_kutta.c  explicit Runge-Kutta steps and whole stretches of the loop
 *   radau.c        implicit steps: Radau IIA on the KKT-sized Newton systems (band LU)
 *   functions.c    any generated function of the model's array, called by its place
 *   layout.c       sizes, offsets and codes, checked against library.py's mirrors
 * The structs below are mirrored field by field in library.py (ctypes), which
 * checks them against dl_layout when it loads the library.
 */
#ifndef DL_RUNTIME_H
#define DL_RUNTIME_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

/* Return codes (library.py's CODES). DL_RANK_CHANGED: a dropped row no longer follows
 * from the kept ones (the rank changed since it was measured); DL_NOT_FINITE: a step
 * would start from a time, step size, state or derivative that is not finite;
 * DL_NEAR_SINGULAR: a stretch ended after a step that ended near a singular
 * configuration (the caller measures and decides, numerics/singular.py); DL_STIFF: a
 * stretch ended after the step that made the stiffness detector say stiff; DL_EVENT: a
 * stretch ended before a step whose end a screen flags (an event may lie in it). */
enum { DL_OK = 0, DL_SINGULAR_MASS = 1, DL_SINGULAR_CONSTRAINTS = 2, DL_STEP_TOO_SMALL = 3,
       DL_PROJECTION = 4, DL_OUTPUTS = 5, DL_RANK_CHANGED = 6, DL_NOT_FINITE = 7,
       DL_INPUT = 8, DL_NEAR_SINGULAR = 9, DL_STIFF = 10, DL_EVENT = 11 };

typedef void (*scatter_state)(const int64_t *, const void *, const void *, const double *,
                              const double *, const double *, const double *, double *);
typedef void (*scatter_static)(const int64_t *, const void *, const void *, const double *,
                               const double *, const double *, double *);
typedef void (*flat_state)(const double *, const double *, const double *, const double *,
                           double *);
typedef void (*flat_static)(const double *, const double *, const double *, double *);

/* One generated function: a scatter driver (K != NULL, adds into out) or a flat one
 * (fn NULL: not generated). Its n_args arguments are arrays, the parameter vector last
 * (dl_call passes the run's d->p there); see codegen/registry.py. */
typedef struct {
  void *fn;
  const int64_t *K;
  const void *index;
  const void *target;
  int64_t size;
  int64_t n_args;
} dl_function;

/* The generated functions the runtime calls, by their place in dl_model.fn: the
 * registry's `native` numbers (codegen/registry.py; library.py checks them). */
enum { DL_FN_KKT = 0, DL_FN_VELOCITY = 1, DL_FN_POSITION = 2, DL_FN_ENERGY = 3,
       DL_FN_RESIDUAL_JACOBIANS = 4, DL_FN_COUNT = 5 };

/* The most arguments dl_call passes a generated function. */
enum { DL_MAX_ARGS = 8 };

/* A model as the runtime sees it: what is constant for a compiled model, its Schur
 * structure, its kept rows and its stabilization. C only reads it (const everywhere),
 * so one dl_model serves any number of runs at once, on any threads; what a run writes
 * is its dl_data. */
typedef struct {
  int64_t n, m, nM, nA, n_hol;
  dl_function fn[DL_FN_COUNT];
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
  /* the 1 x 1 blocks without internal rows, solved in flat loops (see unit_factor) */
  const int64_t *unit;        /* n_blocks: 1 for such a block */
  int64_t n_unit, n_unit_pairs, n_unit_gram;
  const int64_t *unit_slot, *unit_mat;                      /* n_unit */
  const int64_t *unit_pair_vec, *unit_pair_row, *unit_pair_slot, *unit_pair_mat;
  const int64_t *unit_gram_target, *unit_gram_i, *unit_gram_j;  /* n_unit_gram */
  /* kkt_in_layout: the kkt function writes straight into blocks (M), u (f by slot), a
   * (A) and c, all inside dl_data.values; else values is [M, f, A, c] and load_kkt moves
   * them */
  int64_t kkt_in_layout;
  /* dependent rows left out of the solve (a closed loop's redundant joint rows): their
   * pairs follow the others' (n_pairs on) and only load A, the products with A and the
   * check that qdd still meets them (dropped_rtol, as the Python loop's) see them;
   * their multipliers are zero */
  int64_t n_dropped_pairs, n_dropped;
  const int64_t *dropped_rows;
  double dropped_rtol;
} dl_model;

/* What the held KKT factors (dl_data's blocks, y, elim, S) were made from. Kept as a
 * struct of its own inside dl_data: the factors are the data's work arrays, so a
 * factorization cannot outlive or move apart from its data, but the record of which
 * rows it holds is read by every solve and reset by every factorization together. */
typedef struct {
  const unsigned char *active;  /* the rows of the held factors (NULL: all) */
  unsigned char *mask;        /* m: dl_kkt_factor's copy of its rows (active points here) */
  double *fold;               /* n_pairs: weight of each folded internal pair (0: not) */
  double *rows;               /* m: a right-hand side's rows, then its multipliers */
  int64_t factored;           /* 1 while the factors are the KKT matrix's of dl_kkt_factor */
} dl_factor;

/* The friction forces of a contact segment's sliding contacts (friction.c,
 * native/friction.py), computed before each evaluation where the model takes them as
 * inputs: contact k slides along its direction d_k (of its sliding velocities, rows
 * [start[k], start[k+1]) of the tangent lists) with the force -mu_k N_k d_k, N_k the
 * multiplier of its normal row normal[k] in the run's model with these forces acting.
 * The model's generalized force is linear in them (A_t^T F), so the N solve one
 * linear system: the run's KKT system solved without friction and once per sliding
 * contact with -mu_k A_t(k)^T d_k, then (I - R) N = N_0 (contacts/friction.py's
 * solve_sliding). Each tangent row's value (A qd + b) and A are read from the watched
 * model's velocity values (vel: [A values, b], with its own parameter vector p, the
 * run's inputs copied into it: p[copy_to[i]] = run p[copy_from[i]]) by the terms
 * [term_start[j], term_start[j+1]) of term_value at columns term_col (-1: b). The
 * direction is the sliding velocity's s / |s|, kept at the segment's start one
 * (start_direction, written by the caller at each segment's start) where s does not
 * run along it. Where the run drops rows as dependent, the multipliers are first made
 * the minimum-norm ones over the group of rows joined to the dropped ones (as the
 * screens' group: group_*, read from the run's velocity values run_vel). */
typedef struct {
  int64_t n_sliding;
  const int64_t *normal, *start, *slot, *term_start, *term_value, *term_col;
  const double *mu, *start_direction;
  dl_function velocity;            /* the watched model's */
  double *p, *vel;
  /* the contacts starting to slide from rest in the segment (onset[k] 1, written by
   * the caller): their friction is Coulomb's law at the level of accelerations
   * (friction.c's onset_directions), found from the last found at the segment's steps
   * (last_direction: n_tangent, by tangent row, NaN from the segment's start until
   * one is found, not written where dl_data's looking; then n_tangent more, the copy a
   * stretch keeps at each step's start: keep_onset_memory), else from their start
   * directions; the tangent rows'
   * accelerations need the watched model's c (its KKT values, flat: c
   * from c_at, at each tangent's row tangent_row); Newton's method with iterations,
   * difference, rounding, its line search's smallest_step, stalled and free_steps as
   * friction.py's onset_friction */
  const int64_t *onset, *tangent_row;
  double *last_direction;
  dl_function kkt;
  double *kkt_values;
  int64_t c_at, iterations, free_steps;
  double difference, rounding, smallest_step, stalled;
  int64_t n_copy;
  const int64_t *copy_from, *copy_to;
  dl_function run_velocity;        /* the run's model's (set with a group) */
  double *run_vel;
  int64_t n_group, n_group_kept;
  const int64_t *group_row, *group_start, *group_entry, *group_col;
  double dependent_rtol;
  double *work;                    /* native/friction.py's work size */
} dl_friction;

/* Everything one run writes: its parameter vector, its work arrays, its factorization,
 * its inputs. One per run (or per factorization object); never shared between threads. */
typedef struct {
  double *p;                  /* the parameter vector (the inputs' slots written in) */
  double *values, *vel_values, *psi, *blocks, *a, *y, *u, *S, *r, *lambda, *qdd, *q_trial;
  double *elim, *error_work;  /* error_work: 4 n */
  double *c;                  /* the KKT right-hand side (in values) */
  dl_factor factor;
  /* the model's inputs (NULL: none): before every evaluation of the KKT values the state
   * is copied into input_state ([q, qd], 2 n) and inputs(t) writes their values into p;
   * non-zero if it failed (DL_INPUT) */
  int (*inputs)(double t);
  double *input_state;
  /* The smallest pivot ratio of the last factorization of A A^T with every row active
   * (factor_schur: band_conditioning), and the band rows' diagonals before it. */
  double conditioning;
  double *gram_diagonal;      /* m */
  /* n_unit: the 1 x 1 masses of the last factorization and 1 / sqrt of them */
  double *unit_mass, *unit_root;
  /* the sliding contacts' friction forces, written into p after the inputs (NULL: none;
   * friction.c) */
  const dl_friction *friction;
  /* 1 while the screens or the outputs evaluate at a state of their own: the friction's
   * onset search does not remember what it finds there (the steps' evaluations are
   * then the same function whether or not they were looked at in between) */
  int64_t looking;
} dl_data;

/* One Runge-Kutta method: scipy.integrate's tableau. */
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
  /* the controller (steppers/controller.py's PIController, whose values these are):
   * h *= safety err^-alpha err_old^beta within [min_factor, max_factor] */
  double alpha, beta;
  double err_old;             /* its state: the last accepted step's error (>= error_floor) */
  double safety, min_factor, max_factor, error_floor;
  /* the last attempt's stiffness estimate h |lambda| (steppers/stiffness.py), and the
   * detector run by dl_rk_run: its constants (stiff_limit 0: off) and its memory */
  double h_lambda, stiff_limit;
  int64_t stiff_after, calm_after, stiff_count, calm_count;
} dl_stepper;

/* The screens of a stretch's events (screens.c, native/screens.py): values C can
 * evaluate at a step's projected end that are below their margin wherever the
 * events (Python functions, terminal, falling through 0, positive at the start) may
 * have fired in the step. A flagged step ends the stretch before it is counted
 * (DL_EVENT): the caller takes it itself and locates the events. Each value:
 *   position: psi[pos_at[k]] - pos_floor[k] of the watched model, margin
 *             margin (1 + max |q|);
 *   rate:     sum over e in [rate_start[k], rate_start[k+1]) of rate_weight[e] times
 *             vel[rate_value[e]] (times qd[rate_col[e]] if >= 0), the watched
 *             model's velocity values [A values, b], less rate_floor[k], margin
 *             margin (1 + max |qd|);
 *   force:    lambda[force_row[k]] of the run's own model, margin
 *             force_rtol (1 + max |lambda|);
 *   cone:     cone_mu[k] lambda[cone_normal[k]] - |lambda[cone_tangent[j]]| over j in
 *             [cone_start[k], cone_start[k+1]), margin as force.
 * Where the run's model drops rows as dependent (their multipliers 0 in its solve),
 * lambda is first made what the events see (screens.c's minimum_norm): the group's
 * rows (group_row, the kept ones first, n_group_kept of them; the rows coupled to the
 * dropped ones through shared coordinates) get the minimum-norm multipliers, and the
 * held contacts' tangent rows (held_row, kept first; held_normal: each one's normal
 * row; n_held 0: none dropped) the friction shared in proportion to the normal forces.
 * Each group's rows are read from the run's model's velocity values (run_vel) by the
 * entries [*_start[i], *_start[i+1]) of *_entry at columns *_col. */
typedef struct {
  dl_function position, velocity;  /* the watched model's (only what is used is set) */
  const double *p;                 /* its parameter vector */
  double *psi, *vel;               /* work: their values */
  int64_t n_position;
  const int64_t *pos_at;
  const double *pos_floor;
  int64_t n_rate;
  const int64_t *rate_start, *rate_value, *rate_col;
  const double *rate_weight, *rate_floor;
  int64_t n_force;
  const int64_t *force_row;
  int64_t n_cone;
  const int64_t *cone_normal, *cone_start, *cone_tangent;
  const double *cone_mu;
  double margin, force_rtol;
  double *lambda, *ydot;           /* work: the run's model's m and 2 n */
  dl_function run_velocity;        /* the run's model's (set with a group) */
  double *run_vel;                 /* work: its values [A values, b] */
  int64_t n_group, n_group_kept;
  const int64_t *group_row, *group_start, *group_entry, *group_col;
  int64_t n_held, n_held_kept;
  const int64_t *held_row, *held_normal, *held_start, *held_entry, *held_col;
  double dependent_rtol;           /* a dropped row's residual off the kept ones' span */
  double *spread, *work;           /* work: 2 m (the multipliers seen, then with the held
                                    * friction shared), and the dense parts */
} dl_screens;

/* One call of dl_rk_run: where the outputs go, how to project, when to return. */
typedef struct {
  const double *t_eval;       /* n_eval output times in the direction of integration, or
                               * n_eval < 0: every step end */
  int64_t n_eval, next_eval;  /* next_eval: the first output time after st->t */
  const unsigned char *holonomic;  /* dl_project's arguments */
  int64_t max_newton, max_full;
  double position_tol, accept_tol;
  int64_t max_steps;          /* budget of one call: steps, and seconds (wall clock) */
  double max_seconds;
  int64_t capacity;           /* rows of t_out and y_out */
  double *t_out, *y_out;
  int64_t n_steps, n_out;     /* done by this call */
  double t_old;               /* the start of its last step */
  double *y_new, *y_end;      /* work, n_state each */
  double *rows;               /* work: the interpolant, max(n_P, n_D + 3) rows of n_state */
  double near2;               /* a step ending with conditioning below this ends the call */
  const dl_screens *screens;  /* the events' screens, or NULL: none */
} dl_run;

/* The reduced Newton matrix of an implicit step (radau.c, native/radau.py): where each
 * value goes in its band, for one model and set of kept rows (C only reads it). The
 * matrix [[M + c r1_v + c^2 r1_q, -A^T], [A + c r2_v + c^2 r2_q, 0]] (N = n + kept rows
 * unknowns, permuted by perm into a band of kl sub- and ku superdiagonals, LAPACK's
 * band storage of ldab = 2 kl + ku + 1 rows) is made from the KKT function's values
 * (fixed: M, A and -A^T, at fixed_src with fixed_sign) and the residuals' Jacobians
 * (v: r1_v and r2_v, times c; q: r1_q and r2_q, times c^2), each added at its *_dst. The
 * right-hand side's products take the same Jacobian values at (row, col): row among
 * the N unknowns before the permutation, col a coordinate. */
typedef struct {
  int64_t N, kl, ku, ldab;
  const int64_t *perm;          /* N: the band place of each unknown */
  int64_t kkt_size, jac_size;   /* the values' buffers: the kkt function's, the Jacobians' */
  int64_t n_fixed;
  const int64_t *fixed_src, *fixed_dst;
  const double *fixed_sign;
  int64_t n_v;
  const int64_t *v_src, *v_dst, *v_row, *v_col;
  int64_t n_q;
  const int64_t *q_src, *q_dst, *q_row, *q_col;
} dl_newton;

/* One Radau solver's state between steps (scipy's Radau's attributes: h_abs_old and
 * error_norm_old < 0 stand for None), its held linearization and factors, the last
 * step's interpolant (the next step's Newton guess) and its work arrays. */
typedef struct {
  double t, t_old, t_bound, direction, rtol, max_step, newton_tol;
  const double *atol;           /* n_state */
  double h_abs, h_abs_old, error_norm_old;
  int64_t current_jac, jac_ready, lu_ready;
  int64_t nfev, njev, nlu;
  double *kkt, *jac;            /* the held linearization's values */
  double c_real, c_complex_re, c_complex_im;  /* the c = h / MU of the held factors */
  double *lu_real, *lu_complex; /* ldab x N, real and complex (interleaved) */
  int64_t *piv_real, *piv_complex;
  int64_t has_sol;              /* the last step's interpolant: y_old + Q [x, x^2, x^3] */
  double sol_t_old, sol_h;
  double *sol_Q, *sol_y_old;    /* 3 x n_state, n_state */
  double *work, *cwork, *stage_work;  /* max(2n + m, n + 2N); 2n + 2N complex; 17 n_state */
} dl_radau;

/* Small helpers are inlined where the block size is a constant (see BY_SIZE); the
 * functions one source calls in another are hidden (not exported, not interposable),
 * so the compiler may inline them across sources like static ones. */
#define DL_INLINE static inline __attribute__((always_inline))
#define DL_INTERNAL __attribute__((visibility("hidden")))

DL_INLINE double dot(const double *x, const double *y, int64_t n) {
  double s = 0.0;
  for (int64_t i = 0; i < n; ++i) s += x[i] * y[i];
  return s;
}

DL_INLINE double max_abs(const double *x, int64_t n) {
  double m = 0.0;
  for (int64_t i = 0; i < n; ++i) m = fabs(x[i]) > m ? fabs(x[i]) : m;
  return m;
}

DL_INLINE int all_finite(const double *x, int64_t n) {
  for (int64_t i = 0; i < n; ++i)
    if (!isfinite(x[i])) return 0;
  return 1;
}

DL_INLINE int64_t block_size(const dl_model *md, int64_t b) {
  return md->block_start[b + 1] - md->block_start[b];
}

/* The per-block kernels take the block size nb last; BY_SIZE calls them with a
 * constant nb for the common small blocks (a diagonal M has 1x1 blocks, a quaternion
 * body a 4x4 one), so the compiler unrolls their loops and inlines the helpers. */
#define BY_SIZE(nb, F, ...)                                                               \
  ((nb) == 1 ? F(__VA_ARGS__, 1) : (nb) == 2 ? F(__VA_ARGS__, 2)                          \
   : (nb) == 3 ? F(__VA_ARGS__, 3) : (nb) == 4 ? F(__VA_ARGS__, 4) : F(__VA_ARGS__, nb))

/* The band kernels take the band's half width kd last; BY_WIDTH calls them with a
 * constant kd for the common narrow bands (2 rows a joint: 3; 3 rows: 5; 5 rows: 9),
 * so that the loops of a full-width row unroll. */
#define BY_WIDTH(kd, F, ...)                                                              \
  ((kd) == 1 ? F(__VA_ARGS__, 1) : (kd) == 2 ? F(__VA_ARGS__, 2)                          \
   : (kd) == 3 ? F(__VA_ARGS__, 3) : (kd) == 4 ? F(__VA_ARGS__, 4)                        \
   : (kd) == 5 ? F(__VA_ARGS__, 5) : (kd) == 9 ? F(__VA_ARGS__, 9) : F(__VA_ARGS__, kd))

/* Small dense kernels (kkt.c's mass blocks, screens.c's Gram matrices). */
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
DL_INLINE void forward(const double *restrict L, int64_t n, double *restrict x) {
  for (int64_t i = 0; i < n; ++i) {
    double s = x[i];
    for (int64_t k = 0; k < i; ++k) s -= L[i * n + k] * x[k];
    x[i] = s * L[i * n + i];
  }
}

/* x = L^-1 b (b left as it is) */
DL_INLINE void forward_into(const double *restrict L, int64_t n, const double *restrict b,
                            double *restrict x) {
  for (int64_t i = 0; i < n; ++i) {
    double s = b[i];
    for (int64_t k = 0; k < i; ++k) s -= L[i * n + k] * x[k];
    x[i] = s * L[i * n + i];
  }
}

/* x <- L^-T x */
DL_INLINE void backward(const double *restrict L, int64_t n, double *restrict x) {
  for (int64_t i = n - 1; i >= 0; --i) {
    double s = x[i];
    for (int64_t k = i + 1; k < n; ++k) s -= L[k * n + i] * x[k];
    x[i] = s * L[i * n + i];
  }
}

/* kkt.c: the generated functions, A's values, the KKT factorization and solves */
DL_INTERNAL void eval_state(const dl_function *F, double t, const double *q, const double *qd,
                            const double *p, double *out);
DL_INTERNAL void eval_static(const dl_function *F, double t, const double *q, const double *p,
                             double *out);
DL_INTERNAL void load_pairs(const dl_model *md, dl_data *d, const double *Av);
DL_INTERNAL void add_A_times(const dl_model *md, const dl_data *d, const double *x, double w,
                             double *out);
DL_INTERNAL int load_inputs(const dl_model *md, dl_data *d, double t, const double *q,
                            const double *qd);
DL_INTERNAL int eval_kkt(const dl_model *md, dl_data *d, double t, const double *q,
                         const double *qd);
DL_INTERNAL int dl_solve(const dl_model *md, dl_data *d, double *qdd, double *lambda);
DL_INTERNAL int factor_schur(const dl_model *md, dl_data *d, const unsigned char *active);
DL_INTERNAL void solve_schur(const dl_model *md, dl_data *d, double *rhs, double *x);
int dl_rhs(const dl_model *md, dl_data *d, double t, const double *y, double *ydot,
           double *lambda);
int dl_kkt_factor(const dl_model *md, dl_data *d, const double *values,
                  const unsigned char *active);
int dl_kkt_solve(const dl_model *md, dl_data *d, int64_t k, const double *rhs, int64_t ldr,
                 double *out);

/* outputs.c */
int dl_outputs(const dl_model *md, dl_data *d, int64_t k, const double *times, const double *Y,
               double *qdd, double *lambda, double *force, double *position_residual,
               double *velocity_residual, double *energies);

int dl_inputs(const dl_model *md, dl_data *d, int64_t k, const double *times, const double *Y,
              int64_t offset, int64_t count, double *out);

/* projection.c */
int dl_project(const dl_model *md, dl_data *d, double t, double *y,
               const unsigned char *holonomic, int64_t max_newton, int64_t max_full,
               double position_tol, double accept_tol);

/* runge_kutta.c */
int dl_stages(const dl_model *md, dl_data *d, const double *A, int64_t lda, const double *C,
              int64_t row0, int64_t j0, int64_t j1, double t, double h, const double *y,
              double *K, double *stage, int64_t *nfev);
int dl_rk_step(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st,
               const double *y, double *K, double *y_new, double *stage);
int dl_rk_run(const dl_model *md, dl_data *d, const dl_tableau *tb, dl_stepper *st, dl_run *run,
              double *y, double *K, double *stage);

/* radau.c */
int dl_radau_step(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                  const double *y, const double *f, double *y_new, double *f_new, double *Z);
int dl_radau_run(const dl_model *md, dl_data *d, const dl_newton *nw, dl_radau *st,
                 dl_run *run, double *y, double *f, double *Z);

/* screens.c: 1 when a screen of the stretch flags the end (t, y) of a step (lambda:
 * the multipliers there, or NULL: solved here if a screen needs them) */
DL_INTERNAL int screened(const dl_model *md, dl_data *d, const dl_screens *sc, double t,
                         const double *y, const double *lambda);

/* screens.c: a group's minimum-norm multipliers (see dl_screens) */
DL_INTERNAL int group_minimum_norm(int64_t n, int64_t m, int64_t nr, int64_t nk,
                                   const int64_t *row, const int64_t *start,
                                   const int64_t *entry, const int64_t *col, const double *vel,
                                   double rtol, double *work, const double *lambda,
                                   double *out);

/* friction.c: the sliding contacts' friction forces at (t, q, qd) into d->p */
DL_INTERNAL void keep_onset_memory(const dl_data *d, int restore);
DL_INTERNAL int load_friction(const dl_model *md, dl_data *d, double t, const double *q,
                              const double *qd);

/* functions.c */
int dl_call(const dl_model *md, const dl_data *d, int64_t which, const double *const *args,
            double *out);

/* layout.c: one entry per struct size ("dl_model"), field offset ("dl_model.n"), return
 * code ("DL_OK") and function place ("DL_FN_KKT"), for library.py to compare with its
 * mirrors */
typedef struct {
  const char *name;
  int64_t value;
} dl_layout_entry;
int64_t dl_layout(const dl_layout_entry **entries);

/* ---- shared by the stretches of steps (runge_kutta.c, radau.c) ---- */

/* Seconds on the monotonic clock: a call's budget serves Ctrl-C and the progress bar,
 * which wait on the wall clock, and it is read in nanoseconds where clock() (the
 * process's CPU time, summed over its threads) is a system call of about 0.5 us. */
DL_INLINE double wall_seconds(void) {
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

/* dl_project with a stretch's arguments. */
DL_INLINE int run_project(const dl_model *md, dl_data *d, const dl_run *run, double t,
                          double *y) {
  return dl_project(md, d, t, y, run->holonomic, run->max_newton, run->max_full,
                    run->position_tol, run->accept_tol);
}

/* The end of a stretch's step at t_new (its state in run->y_new): *count outputs fall
 * in the step (1 at every step end without t_eval), *hi is the output time after them,
 * and the end is projected into run->y_end. DL_OUTPUTS if the buffer cannot hold them. */
DL_INLINE int end_of_step(const dl_model *md, dl_data *d, dl_run *run, double t_new,
                          double dir, int64_t *hi, int64_t *count) {
  int64_t k = run->next_eval;
  while (k < run->n_eval && dir * run->t_eval[k] <= dir * t_new) ++k;
  *hi = k;
  *count = run->n_eval < 0 ? 1 : k - run->next_eval;
  if (run->n_out + *count > run->capacity) return DL_OUTPUTS;
  memcpy(run->y_end, run->y_new, (size_t)(2 * md->n) * sizeof(double));
  return run_project(md, d, run, t_new, run->y_end);
}

#endif
