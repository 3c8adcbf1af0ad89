/* A shim for flight code written one vehicle at a time (rcsim_fsw.h is batched).
 *
 * Flight software usually steps one vehicle: step(state, errors) -> on-times.  Define three
 * functions for one run and let this header write the four ABI functions around them:
 *
 *     #include "rcsim_fsw_per_run.h"
 *     typedef struct { double integral[3]; } my_state;
 *     static int32_t my_check(const rcsim_fsw_config *c) { return c->n_jets == 16 ? 0 : -1; }
 *     static int32_t my_init(const rcsim_fsw_config *c, my_state *s) { ...; return 0; }
 *     static int32_t my_step(const rcsim_fsw_config *c, double t_s, const double att_err[3],
 *                            const double rate_err[3], const double omega[3], my_state *s,
 *                            double *on_time_s);  // on_time_s: this run's n_jets values
 *     RCSIM_FSW_PER_RUN(my_state, my_check, my_init, my_step)
 *
 * The loop over runs is here, so the per-call cost is still paid once per cycle for the whole
 * batch; each run's state is its own slot of rcsim's buffer (the flight code keeps none of its
 * own).  A non-zero return from my_step fails that run alone (its status). */
#ifndef RCSIM_FSW_PER_RUN_H
#define RCSIM_FSW_PER_RUN_H

#include "rcsim_fsw.h"

#define RCSIM_FSW_PER_RUN(STATE, CHECK, INIT, STEP)                                            \
    int32_t rcsim_fsw_abi_version(void) { return RCSIM_FSW_ABI_VERSION; }                       \
    int64_t rcsim_fsw_state_bytes(const rcsim_fsw_config *c) {                                  \
        if (c->abi_version != RCSIM_FSW_ABI_VERSION || CHECK(c) != 0) return -1;                \
        return (int64_t)sizeof(STATE);                                                          \
    }                                                                                           \
    int32_t rcsim_fsw_init(const rcsim_fsw_config *c, int64_t n_runs, void *states) {           \
        for (int64_t i = 0; i < n_runs; i++) {                                                  \
            int32_t code = INIT(c, (STATE *)states + i);                                        \
            if (code != 0) return code;                                                         \
        }                                                                                       \
        return 0;                                                                               \
    }                                                                                           \
    int32_t rcsim_fsw_step(const rcsim_fsw_config *c, int64_t n_runs, double t_s,               \
                           const double *att, const double *rate, const double *omega,          \
                           void *states, double *on, int32_t *status) {                         \
        for (int64_t i = 0; i < n_runs; i++)                                                    \
            status[i] = STEP(c, t_s, att + 3 * i, rate + 3 * i, omega + 3 * i,                  \
                             (STATE *)states + i, on + i * c->n_jets);                          \
        return 0;                                                                               \
    }

#endif /* RCSIM_FSW_PER_RUN_H */
