/* The screens of a stretch's events (runtime.h's dl_screens, native/screens.py): is a
 * step's end flagged, so that the stretch ends before the step and the caller takes it
 * with its event functions? A value at or above its margin proves that the event it
 * screens has not fired at the end; one below (or not finite) flags the step. */
#include "runtime.h"

/* `value >= margin` fails for NaN too: a value that is not finite flags the step. */
DL_INLINE int below(double value, double margin) { return !(value >= margin); }

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
      if (below(value, margin)) return 1;
    }
  }
  if (!sc->n_force && !sc->n_cone) return 0;
  if (!lambda) {  /* the multipliers at the end: one more solve */
    if (dl_rhs(md, d, t, y, sc->ydot, sc->lambda) != DL_OK) return 1;
    lambda = sc->lambda;
  }
  const double margin = sc->force_rtol * (1.0 + max_abs(lambda, md->m));
  for (int64_t k = 0; k < sc->n_force; ++k)
    if (below(lambda[sc->force_row[k]], margin)) return 1;
  for (int64_t k = 0; k < sc->n_cone; ++k) {
    double tangential = 0.0;
    for (int64_t j = sc->cone_start[k]; j < sc->cone_start[k + 1]; ++j)
      tangential += lambda[sc->cone_tangent[j]] * lambda[sc->cone_tangent[j]];
    if (below(sc->cone_mu[k] * lambda[sc->cone_normal[k]] - sqrt(tangential), margin))
      return 1;
  }
  return 0;
}
