/* Any generated function of dl_model's array, called by its place (DL_FN_...): the
 * calls a C integrator makes of functions the loop's own code does not know by their
 * arguments (the KKT residuals' Jacobians). The hot loop calls its functions through
 * eval_state and eval_static (kkt.c) instead. */
#include "runtime.h"

/* The argument lists of 1 to DL_MAX_ARGS arrays: their types and the values passed. */
#define DL_T1 const double *
#define DL_T2 DL_T1, const double *
#define DL_T3 DL_T2, const double *
#define DL_T4 DL_T3, const double *
#define DL_T5 DL_T4, const double *
#define DL_T6 DL_T5, const double *
#define DL_T7 DL_T6, const double *
#define DL_T8 DL_T7, const double *
#define DL_V1 a[0]
#define DL_V2 DL_V1, a[1]
#define DL_V3 DL_V2, a[2]
#define DL_V4 DL_V3, a[3]
#define DL_V5 DL_V4, a[4]
#define DL_V6 DL_V5, a[5]
#define DL_V7 DL_V6, a[6]
#define DL_V8 DL_V7, a[7]
#define DL_CALL(TYPES, VALUES)                                                            \
  do {                                                                                    \
    if (F->K)                                                                             \
      ((void (*)(const int64_t *, const void *, const void *, TYPES, double *))F->fn)(    \
          F->K, F->index, F->target, VALUES, out);                                        \
    else                                                                                  \
      ((void (*)(TYPES, double *))F->fn)(VALUES, out);                                    \
  } while (0)

/* Evaluate function `which` into out (F->size values): args holds its arguments but the
 * last (a scalar such as t as a pointer to it), the run's
 * d->p is passed as the parameter vector.
 * DL_OK, or -1 when `which` names no generated function. */
int dl_call(const dl_model *md, const dl_data *d, int64_t which, const double *const *args,
            double *out) {
  if (which < 0 || which >= DL_FN_COUNT) return -1;
  const dl_function *F = &md->fn[which];
  if (!F->fn || F->n_args < 1 || F->n_args > DL_MAX_ARGS) return -1;
  if (F->size == 0) return DL_OK;
  const double *a[DL_MAX_ARGS];
  for (int64_t i = 0; i + 1 < F->n_args; ++i) a[i] = args[i];
  a[F->n_args - 1] = d->p;
  if (F->K) memset(out, 0, (size_t)F->size * sizeof(double));  /* a driver adds */
  switch (F->n_args) {
    case 1: DL_CALL(DL_T1, DL_V1); break;
    case 2: DL_CALL(DL_T2, DL_V2); break;
    case 3: DL_CALL(DL_T3, DL_V3); break;
    case 4: DL_CALL(DL_T4, DL_V4); break;
    case 5: DL_CALL(DL_T5, DL_V5); break;
    case 6: DL_CALL(DL_T6, DL_V6); break;
    case 7: DL_CALL(DL_T7, DL_V7); break;
    default: DL_CALL(DL_T8, DL_V8); break;
  }
  return DL_OK;
}
