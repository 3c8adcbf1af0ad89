/* rcsim flight-software C ABI, version 1 (docs/flight_software.md, "C flight code").
 *
 * A shared library that implements these four functions can be flown by rcsim as a controller:
 *     rcsim maneuver --controller library:path/to/libfsw.so ...
 *     [controller] library = "path/to/libfsw.so"          (a campaign spec)
 *
 * Batched: rcsim calls rcsim_fsw_step once per control cycle for every run of a batch (n_runs
 * of them, one after the other in memory); the library loops over the runs.  rcsim owns the
 * state: one buffer of rcsim_fsw_state_bytes() bytes per run, contiguous, so runs stay
 * independent and any run replays alone.  The library must not keep run state of its own
 * (globals), and must not retain the pointers it is given past the call.
 *
 * Arrays are row-major float64: att_err_rad is (n_runs, 3), on_time_s is (n_runs, n_jets).
 * Units are SI: radians, rad/s, seconds.  Frames: body (roll, pitch, yaw = x, y, z).
 *
 * Return codes: 0 is success.  rcsim_fsw_init and rcsim_fsw_step return non-zero for an error
 * of the whole call; status[i] != 0 from rcsim_fsw_step fails run i alone (its failure reason
 * records the code).  An on-time that is NaN, negative or longer than the cycle fails the run
 * too.  A crash (segfault) inside the library ends only the process that called it: rcsim
 * flies library controllers in worker processes and names the run and cycle.
 */
#ifndef RCSIM_FSW_H
#define RCSIM_FSW_H

#include <stdint.h>

#define RCSIM_FSW_ABI_VERSION 1

#ifdef __cplusplus
extern "C" {
#endif

/* What rcsim tells the library once, at init and with every call. */
typedef struct rcsim_fsw_config {
    int32_t abi_version; /* RCSIM_FSW_ABI_VERSION of the caller */
    int32_t n_jets;      /* the vehicle's jet count: the width of on_time_s */
    double cycle_s;      /* the control cycle [s] (the vehicle's flight-software profile) */
    int32_t n_values;    /* named numbers, SI, units in the names: the profile's numbers
                            (cycle_s, maneuver_rate_rad_s, rate_deadband_rad_s, ...: the
                            fields of rcsim.spacecraft.control_profile.ControlProfile), then the
                            spec's [controller.params] that are numbers */
    const char *const *names; /* n_values NUL-terminated names */
    const double *values;     /* n_values values */
    const double *jet_torque_n_m; /* (n_jets, 3) each jet's nominal torque about the CG [N m] */
    int32_t n_texts;                 /* named strings: the spec's [controller.params] that are
                                        strings, as given (a table file, say) */
    const char *const *text_names;   /* n_texts NUL-terminated names */
    const char *const *text_values;  /* n_texts NUL-terminated values */
} rcsim_fsw_config;

/* The ABI version the library was built for: rcsim refuses any other. */
int32_t rcsim_fsw_abi_version(void);

/* Bytes of state per run (>= 0), or a negative number if the config is refused. */
int64_t rcsim_fsw_state_bytes(const rcsim_fsw_config *config);

/* Initialise n_runs states (n_runs * rcsim_fsw_state_bytes bytes at states). */
int32_t rcsim_fsw_init(const rcsim_fsw_config *config, int64_t n_runs, void *states);

/* One control cycle for n_runs runs at time t_s [s]: navigation errors in, on-times out. */
int32_t rcsim_fsw_step(const rcsim_fsw_config *config, int64_t n_runs, double t_s,
                       const double *att_err_rad,    /* (n_runs, 3) */
                       const double *rate_err_rad_s, /* (n_runs, 3) */
                       const double *omega_rad_s,    /* (n_runs, 3) body rate */
                       void *states,                 /* n_runs states */
                       double *on_time_s,            /* out: (n_runs, n_jets) [s] */
                       int32_t *status);             /* out: (n_runs), 0 = ok */

/* Optional: the name of the text parameter through which the library takes a lookup-table
 * file (rcsim layout), for flight code that flies a table.  With it, `rcsim lookup refine
 * --controller library:...` and `rcsim loop --controller library:...` refine that table with
 * the library flying every candidate: each candidate is written to a file of its own and
 * passed under this name.  Table state kept per process must be keyed by the file (several
 * tables are flown, one batch after another, in one process). */
const char *rcsim_fsw_table_param(void);

/* Optional, with rcsim_fsw_table_param: which table rows each run has fired so far (bit r of
 * rows[i] set: run i started a firing with row r, 0-based), read from the runs' states after a
 * flight.  The refinement judges a changed row on every case whose runs fire it; without this
 * function every run counts as firing every row (the same decisions, many more runs flown). */
int32_t rcsim_fsw_rows_fired(const rcsim_fsw_config *config, int64_t n_runs,
                             const void *states, uint64_t *rows);

#ifdef __cplusplus
}
#endif

#endif /* RCSIM_FSW_H */
