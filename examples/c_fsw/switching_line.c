/* A flight-software library for rcsim's C ABI (rcsim/lookup/c_abi/rcsim_fsw.h): the
 * switching-line controller of examples/plugins/switching_line.py, in C, batched.
 *
 * Per run and axis: s = rate_err + att_err / tau; while |s| exceeds the deadband, fire for the
 * whole cycle the jets that turn that axis alone in the direction that reduces s.  The jets'
 * axes come from their torques (a component below 1e-9 of the largest is zero: the rule of
 * rcsim's Vehicle.axis_signs).  Parameters ([controller.params]): deadband_deg_s (default
 * 0.02) and tau_s (default 20).  No state: rcsim_fsw_state_bytes is 0.
 *
 * The arithmetic is the Python example's, in the same order, so the two command the same
 * on-times bit for bit (tests/lookup/test_c_library.py).  Build: examples/c_fsw/build.sh. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "rcsim_fsw.h"

#define PI 3.141592653589793

static double value(const rcsim_fsw_config *c, const char *name, double fallback) {
    for (int32_t i = 0; i < c->n_values; i++)
        if (strcmp(c->names[i], name) == 0) return c->values[i];
    return fallback;
}

int32_t rcsim_fsw_abi_version(void) { return RCSIM_FSW_ABI_VERSION; }

int64_t rcsim_fsw_state_bytes(const rcsim_fsw_config *c) {
    if (c->abi_version != RCSIM_FSW_ABI_VERSION || c->n_jets <= 0) return -1;
    if (!(value(c, "deadband_deg_s", 0.02) > 0) || !(value(c, "tau_s", 20.0) > 0)) return -2;
    return 0;
}

int32_t rcsim_fsw_init(const rcsim_fsw_config *c, int64_t n_runs, void *states) {
    (void)c; (void)n_runs; (void)states;
    return 0;
}

/* Sign of jet j's torque about axis a if it turns that axis alone, else 0. */
static int pure_sign(const rcsim_fsw_config *c, int32_t j, int a, double big) {
    const double *t = c->jet_torque_n_m + 3 * j;
    int n = 0, sign = 0;
    for (int k = 0; k < 3; k++) {
        if (fabs(t[k]) > big) {
            n++;
            if (k == a) sign = t[k] > 0 ? 1 : -1;
        }
    }
    return n == 1 ? sign : 0;
}

int32_t rcsim_fsw_step(const rcsim_fsw_config *c, int64_t n_runs, double t_s,
                       const double *att, const double *rate, const double *omega, void *states,
                       double *on, int32_t *status) {
    (void)t_s; (void)omega; (void)states;
    const double deadband = value(c, "deadband_deg_s", 0.02) * (PI / 180.0);
    const double tau = value(c, "tau_s", 20.0);
    double largest = 0;
    for (int32_t j = 0; j < 3 * c->n_jets; j++)
        if (fabs(c->jet_torque_n_m[j]) > largest) largest = fabs(c->jet_torque_n_m[j]);
    const double big = 1e-9 * largest;
    for (int64_t i = 0; i < n_runs; i++) {
        double *out = on + i * c->n_jets;
        for (int32_t j = 0; j < c->n_jets; j++) out[j] = 0.0;
        for (int a = 0; a < 3; a++) {
            const double s = rate[3 * i + a] + att[3 * i + a] / tau;
            const int want = s > deadband ? -1 : (s < -deadband ? 1 : 0);
            if (want == 0) continue;
            for (int32_t j = 0; j < c->n_jets; j++)
                if (pure_sign(c, j, a, big) == want) out[j] = c->cycle_s;
        }
        status[i] = 0;
    }
    return 0;
}
