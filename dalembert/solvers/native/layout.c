/* Sizes, field offsets, return codes and the generated functions' places, for
 * library.py to check its ctypes mirrors against when it loads the library: a field
 * added on one side only, or moved, is reported by name instead of corrupting memory.
 * Every field of every mirrored struct is listed; the sizes catch one missing here. */
#include "runtime.h"

#define SIZE(T) {#T, (int64_t)sizeof(T)}
#define FIELD(T, f) {#T "." #f, (int64_t)offsetof(T, f)}
#define CODE(c) {#c, c}

static const dl_layout_entry entries[] = {
  SIZE(dl_function),
  FIELD(dl_function, fn), FIELD(dl_function, K), FIELD(dl_function, index),
  FIELD(dl_function, target), FIELD(dl_function, size), FIELD(dl_function, n_args),
  SIZE(dl_model),
  FIELD(dl_model, n), FIELD(dl_model, m), FIELD(dl_model, nM), FIELD(dl_model, nA),
  FIELD(dl_model, n_hol), FIELD(dl_model, fn), FIELD(dl_model, holonomic),
  FIELD(dl_model, baumgarte), FIELD(dl_model, n_blocks), FIELD(dl_model, block_start),
  FIELD(dl_model, slot_coord), FIELD(dl_model, block_mat), FIELD(dl_model, M_at),
  FIELD(dl_model, n_pairs), FIELD(dl_model, pair_row), FIELD(dl_model, pair_block),
  FIELD(dl_model, pair_vec), FIELD(dl_model, A_at), FIELD(dl_model, block_pairs),
  FIELD(dl_model, block_external), FIELD(dl_model, elim_at), FIELD(dl_model, n_elim_blocks),
  FIELD(dl_model, elim_blocks), FIELD(dl_model, m_band), FIELD(dl_model, kd),
  FIELD(dl_model, band_row), FIELD(dl_model, gram_start), FIELD(dl_model, gram_target),
  FIELD(dl_model, unit), FIELD(dl_model, n_unit), FIELD(dl_model, n_unit_pairs),
  FIELD(dl_model, n_unit_gram), FIELD(dl_model, unit_slot), FIELD(dl_model, unit_mat),
  FIELD(dl_model, unit_pair_vec), FIELD(dl_model, unit_pair_row),
  FIELD(dl_model, unit_pair_slot), FIELD(dl_model, unit_pair_mat),
  FIELD(dl_model, unit_gram_target), FIELD(dl_model, unit_gram_i),
  FIELD(dl_model, unit_gram_j), FIELD(dl_model, kkt_in_layout),
  FIELD(dl_model, n_dropped_pairs), FIELD(dl_model, n_dropped), FIELD(dl_model, dropped_rows),
  FIELD(dl_model, dropped_rtol),
  SIZE(dl_factor),
  FIELD(dl_factor, active), FIELD(dl_factor, mask), FIELD(dl_factor, fold),
  FIELD(dl_factor, rows), FIELD(dl_factor, factored),
  SIZE(dl_data),
  FIELD(dl_data, p), FIELD(dl_data, values), FIELD(dl_data, vel_values), FIELD(dl_data, psi),
  FIELD(dl_data, blocks), FIELD(dl_data, a), FIELD(dl_data, y), FIELD(dl_data, u),
  FIELD(dl_data, S), FIELD(dl_data, r), FIELD(dl_data, lambda), FIELD(dl_data, qdd),
  FIELD(dl_data, q_trial), FIELD(dl_data, elim), FIELD(dl_data, error_work), FIELD(dl_data, c),
  FIELD(dl_data, factor), FIELD(dl_data, inputs), FIELD(dl_data, input_state),
  FIELD(dl_data, conditioning), FIELD(dl_data, gram_diagonal), FIELD(dl_data, unit_mass),
  FIELD(dl_data, unit_root),
  SIZE(dl_tableau),
  FIELD(dl_tableau, n_stages), FIELD(dl_tableau, A), FIELD(dl_tableau, B),
  FIELD(dl_tableau, C), FIELD(dl_tableau, E), FIELD(dl_tableau, E3),
  FIELD(dl_tableau, n_P), FIELD(dl_tableau, P), FIELD(dl_tableau, n_extra),
  FIELD(dl_tableau, A_extra), FIELD(dl_tableau, C_extra), FIELD(dl_tableau, n_D),
  FIELD(dl_tableau, D),
  SIZE(dl_stepper),
  FIELD(dl_stepper, t), FIELD(dl_stepper, h_abs), FIELD(dl_stepper, h_previous),
  FIELD(dl_stepper, t_bound), FIELD(dl_stepper, direction), FIELD(dl_stepper, rtol),
  FIELD(dl_stepper, max_step), FIELD(dl_stepper, atol), FIELD(dl_stepper, nfev),
  FIELD(dl_stepper, alpha), FIELD(dl_stepper, beta), FIELD(dl_stepper, err_old),
  FIELD(dl_stepper, safety), FIELD(dl_stepper, min_factor), FIELD(dl_stepper, max_factor),
  FIELD(dl_stepper, error_floor),
  SIZE(dl_run),
  FIELD(dl_run, t_eval), FIELD(dl_run, n_eval), FIELD(dl_run, next_eval),
  FIELD(dl_run, holonomic), FIELD(dl_run, max_newton), FIELD(dl_run, max_full),
  FIELD(dl_run, position_tol), FIELD(dl_run, accept_tol), FIELD(dl_run, max_steps),
  FIELD(dl_run, max_seconds), FIELD(dl_run, capacity), FIELD(dl_run, t_out),
  FIELD(dl_run, y_out), FIELD(dl_run, n_steps), FIELD(dl_run, n_out), FIELD(dl_run, t_old),
  FIELD(dl_run, y_new), FIELD(dl_run, y_end), FIELD(dl_run, rows), FIELD(dl_run, near2),
  CODE(DL_OK), CODE(DL_SINGULAR_MASS), CODE(DL_SINGULAR_CONSTRAINTS), CODE(DL_STEP_TOO_SMALL),
  CODE(DL_PROJECTION), CODE(DL_OUTPUTS), CODE(DL_RANK_CHANGED), CODE(DL_NOT_FINITE), CODE(DL_INPUT),
  CODE(DL_NEAR_SINGULAR),
  CODE(DL_FN_KKT), CODE(DL_FN_VELOCITY), CODE(DL_FN_POSITION), CODE(DL_FN_ENERGY),
  CODE(DL_FN_RESIDUAL_JACOBIANS), CODE(DL_FN_COUNT), CODE(DL_MAX_ARGS),
};

/* The table above: *entries points to it, the count is returned. */
int64_t dl_layout(const dl_layout_entry **table) {
  *table = entries;
  return (int64_t)(sizeof entries / sizeof entries[0]);
}
