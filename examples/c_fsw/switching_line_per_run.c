/* The switching-line example (switching_line.c) written one vehicle at a time, batched by
 * rcsim's shim (rcsim/lookup/c_abi/rcsim_fsw_per_run.h): how flight code that steps a single
 * vehicle flies in rcsim.  It keeps a count of its firing cycles in its state, to show a
 * per-run state; its on-times are the batched example's, bit for bit
 * (tests/lookup/test_c_library.py).  Build: sh examples/c_fsw/build.sh THIS.c OUT.so */
#include <math.h>
#include <string.h>

#include "rcsim_fsw_per_run.h"

#define PI 3.141592653589793

typedef struct {
    int64_t firing_cycles; /* cycles in which any jet fired: this run's own history */
} damper_state;

static double value(const rcsim_fsw_config *c, const char *name, double fallback) {
    for (int32_t i = 0; i < c->n_values; i++)
        if (strcmp(c->names[i], name) == 0) return c->values[i];
    return fallback;
}

static int32_t check(const rcsim_fsw_config *c) {
    return (c->n_jets > 0 && value(c, "deadband_deg_s", 0.02) > 0 && value(c, "tau_s", 20.0) > 0)
               ? 0
               : -1;
}

static int32_t init(const rcsim_fsw_config *c, damper_state *s) {
    (void)c;
    s->firing_cycles = 0;
    return 0;
}

/* Sign of jet j's torque about axis a if it turns that axis alone, else 0. */
static int pure_sign(const rcsim_fsw_config *c, int32_t j, int a, double big) {
    const double *t = c->jet_torque_n_m + 3 * j;
    int n = 0, sign = 0;
    for (int k = 0; k < 3; k++)
        if (fabs(t[k]) > big) {
            n++;
            if (k == a) sign = t[k] > 0 ? 1 : -1;
        }
    return n == 1 ? sign : 0;
}

static int32_t step(const rcsim_fsw_config *c, double t_s, const double att[3],
                    const double rate[3], const double omega[3], damper_state *s, double *on) {
    (void)t_s; (void)omega;
    const double deadband = value(c, "deadband_deg_s", 0.02) * (PI / 180.0);
    const double tau = value(c, "tau_s", 20.0);
    double largest = 0;
    for (int32_t j = 0; j < 3 * c->n_jets; j++)
        if (fabs(c->jet_torque_n_m[j]) > largest) largest = fabs(c->jet_torque_n_m[j]);
    int fired = 0;
    for (int32_t j = 0; j < c->n_jets; j++) on[j] = 0.0;
    for (int a = 0; a < 3; a++) {
        const double sw = rate[a] + att[a] / tau;
        const int want = sw > deadband ? -1 : (sw < -deadband ? 1 : 0);
        if (want == 0) continue;
        for (int32_t j = 0; j < c->n_jets; j++)
            if (pure_sign(c, j, a, 1e-9 * largest) == want) {
                on[j] = c->cycle_s;
                fired = 1;
            }
    }
    s->firing_cycles += fired;
    return 0;
}

RCSIM_FSW_PER_RUN(damper_state, check, init, step)
