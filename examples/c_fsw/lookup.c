/* The pattern-recognition lookup controller (Gambone, sec. II) in plain C, for rcsim's C ABI
 * (rcsim/lookup/c_abi/rcsim_fsw.h): what a flight-software team would write, flown back to
 * back against rcsim's own (rcsim/lookup/pattern_recognition.py) by
 * `rcsim compare controllers`.  Jet tables only (a channel table's recipe is not ported).
 *
 * Parameters ([controller.params]): table = "path/to/table.csv", a lookup table in rcsim's
 * layout (case, roll_deg_s, pitch_deg_s, yaw_deg_s, jet_01 ... jet_NN; the packaged
 * rcsim/lookup/data/generated_table.csv).  The logic's inputs are the vehicle profile's
 * numbers the config carries (maneuver_limit_rad, maneuver_rate_rad_s, rate_deadband_rad_s,
 * on_time_limit_s, hold_time_s, maneuver_band_rad, maneuver_hysteresis_rad, cycle_s).
 *
 * Each cycle, per run: (1) the rate error, with the maneuver rate toward zero attitude error
 * above the maneuver limit (with hysteresis); (2) a per-axis dead band; (3) the table case
 * of the sign pattern of the rate change needed; (4) each axis's fraction of the case's rate;
 * (5) gates: a jet fires anew only if its own and its opposing jets' remaining on-times are
 * under the on-time limit, its axis's hold timer has run out, and the attitude error is
 * outside the no-firing band around the maneuver limit; an axis with a new firing is
 * re-planned; (6) delivery, min(remaining, cycle), and the hold timer started when an axis's
 * firing ends.  The arithmetic is rcsim's, operation for operation, so the two command the
 * same on-times bit for bit (tests/lookup/test_c_lookup_example.py).
 *
 * Build: sh examples/c_fsw/build.sh examples/c_fsw/lookup.c OUT.so */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rcsim_fsw.h"

#define N_AXES 3
#define N_CASES 26
#define MAX_JETS 64
#define TIMER_EPS_S 1e-9 /* "a timer has run out" (pattern_recognition.py: _TIMER_EPS_S) */
#define PI 3.141592653589793

/* The table and what the logic learns from it: loaded once per process (the table file is
 * the same for every call of a campaign). */
static struct {
    char path[4096];
    int n_jets;
    double rate_abs[N_CASES][N_AXES]; /* |rate command| [rad/s] */
    double times[N_CASES][MAX_JETS];  /* firing times [s] */
    int64_t case_of_code[27];
    int axis[MAX_JETS], group[MAX_JETS], opp[MAX_JETS];
} T;

/* Per-run state, owned by rcsim. */
typedef struct {
    double remaining_s[MAX_JETS];
    double hold_s[N_AXES];
    uint8_t maneuvering, has_before;
    uint64_t rows; /* bit r: a firing started with table row r (rcsim_fsw_rows_fired) */
} run_state;

static double value(const rcsim_fsw_config *c, const char *name) {
    for (int32_t i = 0; i < c->n_values; i++)
        if (strcmp(c->names[i], name) == 0) return c->values[i];
    return NAN;
}

static const char *text(const rcsim_fsw_config *c, const char *name) {
    for (int32_t i = 0; i < c->n_texts; i++)
        if (strcmp(c->text_names[i], name) == 0) return c->text_values[i];
    return NULL;
}

static inline double np_min(double a, double b) { return (a < b || isnan(a)) ? a : b; }
static inline double np_max(double a, double b) { return (a > b || isnan(a)) ? a : b; }
static inline int sign_of(double x) { return (x > 0.0) - (x < 0.0); }

/* Read the table and learn each jet's axis, sign and opposing group; 0 on success. */
static int load_table(const char *path, int n_jets) {
    if (strlen(path) >= sizeof T.path || n_jets > MAX_JETS) return -1;
    if (strcmp(T.path, path) == 0 && T.n_jets == n_jets) return 0;
    FILE *f = fopen(path, "r");
    if (f == NULL) return -2;
    char line[8192];
    int rows = 0, ok = fgets(line, sizeof line, f) != NULL; /* the header */
    int signs[N_CASES][N_AXES];
    while (ok && rows < N_CASES && fgets(line, sizeof line, f) != NULL) {
        char *p = line, *end;
        strtod(p, &end); /* case number */
        if (end == p) { ok = 0; break; }
        p = end + 1;
        for (int a = 0; a < N_AXES; a++, p = end + 1) {
            double deg = strtod(p, &end);
            if (end == p) { ok = 0; break; }
            double rad = deg * (PI / 180.0); /* numpy's deg2rad */
            T.rate_abs[rows][a] = fabs(rad);
            signs[rows][a] = sign_of(rad);
        }
        for (int j = 0; ok && j < n_jets; j++, p = end + 1) {
            T.times[rows][j] = strtod(p, &end);
            if (end == p) ok = 0;
        }
        rows++;
    }
    fclose(f);
    if (!ok || rows != N_CASES) return -3;
    for (int k = 0; k < 27; k++) T.case_of_code[k] = -1;
    for (int r = 0; r < N_CASES; r++)
        T.case_of_code[(signs[r][0] + 1) * 9 + (signs[r][1] + 1) * 3 + (signs[r][2] + 1)] = r;
    /* A jet's axis: the one axis whose sign is the same, and nonzero, in every case it fires. */
    for (int j = 0; j < n_jets; j++) {
        int axis = -1, sign = 0, fires = 0;
        int same[N_AXES] = {1, 1, 1}, first[N_AXES] = {0, 0, 0};
        for (int r = 0; r < N_CASES; r++) {
            if (!(T.times[r][j] > 0)) continue;
            for (int a = 0; a < N_AXES; a++) {
                if (!fires) first[a] = signs[r][a];
                else if (signs[r][a] != first[a]) same[a] = 0;
            }
            fires = 1;
        }
        int count = 0;
        for (int a = 0; fires && a < N_AXES; a++)
            if (same[a] && first[a] != 0) { axis = a; sign = first[a]; count++; }
        if (fires && count != 1) return -4; /* not a jet table this logic can fly */
        T.axis[j] = axis;
        T.group[j] = axis >= 0 ? 2 * axis + (sign > 0) : 2 * N_AXES;
        T.opp[j] = axis >= 0 ? 2 * axis + (sign < 0) : 2 * N_AXES;
    }
    strcpy(T.path, path);
    T.n_jets = n_jets;
    return 0;
}

int32_t rcsim_fsw_abi_version(void) { return RCSIM_FSW_ABI_VERSION; }

/* The text parameter that takes the table: rcsim refines that table with this code flying. */
const char *rcsim_fsw_table_param(void) { return "table"; }

int32_t rcsim_fsw_rows_fired(const rcsim_fsw_config *c, int64_t n_runs, const void *states,
                             uint64_t *rows) {
    (void)c;
    const run_state *S = (const run_state *)states;
    for (int64_t i = 0; i < n_runs; i++) rows[i] = S[i].rows;
    return 0;
}

int64_t rcsim_fsw_state_bytes(const rcsim_fsw_config *c) {
    if (c->abi_version != RCSIM_FSW_ABI_VERSION) return -1;
    const char *path = text(c, "table");
    if (path == NULL || load_table(path, c->n_jets) != 0) return -2;
    return (int64_t)sizeof(run_state);
}

int32_t rcsim_fsw_init(const rcsim_fsw_config *c, int64_t n_runs, void *states) {
    (void)c;
    memset(states, 0, (size_t)n_runs * sizeof(run_state));
    return 0;
}

int32_t rcsim_fsw_step(const rcsim_fsw_config *c, int64_t n_runs, double t_s,
                       const double *att, const double *rate, const double *omega, void *states,
                       double *on_all, int32_t *status) {
    (void)t_s; (void)omega;
    const double limit = value(c, "maneuver_limit_rad"), w_m = value(c, "maneuver_rate_rad_s");
    const double rate_limit = value(c, "rate_deadband_rad_s");
    const double on_limit = value(c, "on_time_limit_s"), hold_time = value(c, "hold_time_s");
    const double band = value(c, "maneuver_band_rad"), hyst = value(c, "maneuver_hysteresis_rad");
    const double cycle = c->cycle_s;
    const int n_jets = c->n_jets;
    static const int64_t weight[N_AXES] = {9, 3, 1};
    run_state *S = (run_state *)states;
    for (int64_t i = 0; i < n_runs; i++) {
        run_state *s = S + i;
        const double *e = att + 3 * i, *w = rate + 3 * i;
        /* Step 1: the total attitude error, summed as numpy's einsum sums three squares on
         * x86-64 (roll and yaw first: its SIMD pairs them), and the maneuver flag with its
         * hysteresis.  Summed in another order, theta differs in its last bit now and then,
         * and a maneuver's on-time with it (seen: 1 run in 30, at cycle 547). */
        double theta = sqrt((e[0] * e[0] + e[2] * e[2]) + e[1] * e[1]);
        int above = theta > limit;
        int maneuver = above;
        if (s->has_before && hyst > 0) maneuver = above || (s->maneuvering && theta > limit - hyst);
        double div = theta > 0.0 ? theta : 1.0;
        double need[N_AXES];
        int any_err = 0;
        int64_t code = 0;
        for (int a = 0; a < N_AXES; a++) {
            double err = w[a] + (maneuver ? w_m * (e[a] / div) : 0.0);
            err = fabs(err) < rate_limit ? 0.0 : err; /* step 2 */
            need[a] = -err;
            code += (sign_of(need[a]) + 1) * weight[a];
            any_err |= need[a] != 0.0;
        }
        int64_t cs = T.case_of_code[any_err ? code : 0]; /* step 3 */
        double scale[N_AXES];
        for (int a = 0; a < N_AXES; a++) { /* step 4 */
            double denom = T.rate_abs[cs][a];
            scale[a] = denom > 0.0 ? fabs(need[a]) / denom : 0.0;
        }
        /* Step 5: the gates. */
        double gmax[2 * N_AXES + 1] = {0.0};
        int seen[2 * N_AXES + 1] = {0};
        for (int j = 0; j < n_jets; j++) {
            if (T.axis[j] < 0) continue;
            int g = T.group[j];
            gmax[g] = seen[g] ? np_max(s->remaining_s[j], gmax[g]) : s->remaining_s[j];
            seen[g] = 1;
        }
        int no_fire = fabs(theta - limit) < band;
        int axis_new[N_AXES] = {0, 0, 0};
        double newt[MAX_JETS];
        int fire[MAX_JETS];
        for (int j = 0; j < n_jets; j++) {
            int a = T.axis[j];
            double nt = any_err ? T.times[cs][j] * (a >= 0 ? scale[a] : 0.0) : 0.0;
            double hold_jet = a >= 0 ? s->hold_s[a] : 0.0;
            int gate = (s->remaining_s[j] < on_limit) && (gmax[T.opp[j]] < on_limit) &&
                       (hold_jet <= TIMER_EPS_S) && !no_fire;
            fire[j] = gate && (nt > 0.0);
            if (fire[j] && a >= 0) axis_new[a] = 1;
            newt[j] = nt;
        }
        if (axis_new[0] || axis_new[1] || axis_new[2]) s->rows |= (uint64_t)1 << cs;
        /* Re-plan the axes with a new firing; step 6: delivery and hold timers. */
        double *on = on_all + i * n_jets;
        int fired[N_AXES] = {0, 0, 0}, left[N_AXES] = {0, 0, 0};
        for (int j = 0; j < n_jets; j++) {
            int a = T.axis[j];
            double r = (a >= 0 && axis_new[a]) ? (fire[j] ? newt[j] : 0.0) : s->remaining_s[j];
            on[j] = np_min(r, cycle);
            s->remaining_s[j] = np_max(r - cycle, 0.0);
            if (a >= 0) {
                fired[a] |= on[j] != 0.0;
                left[a] |= s->remaining_s[j] > 0.0;
            }
        }
        for (int a = 0; a < N_AXES; a++)
            s->hold_s[a] = (fired[a] && !left[a]) ? hold_time : np_max(s->hold_s[a] - cycle, 0.0);
        s->maneuvering = (uint8_t)maneuver;
        s->has_before = 1;
        status[i] = 0;
    }
    return 0;
}
