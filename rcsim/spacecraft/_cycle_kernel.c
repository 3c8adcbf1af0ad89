/* The closed loop's per-cycle bookkeeping, compiled (rcsim/spacecraft/cycle_kernel.py).
 *
 * Navigation's quaternion algebra, the valve limits and valve commands, the test for a cycle
 * without switches, the propulsion totals and the end of a cycle are, in numpy, some sixty
 * calls per control cycle on (n_runs, n_jets) arrays, each a few microseconds whatever the run
 * count (rcsim/spacecraft/navigation.py, rcsim/spacecraft/propulsion.py, rcsim/spacecraft/valves.py,
 * rcsim/spacecraft/pieces.py).  These functions do the same arithmetic, operation for operation and
 * in the same order, element by element, in one pass each.  The numpy forms stay the reference
 * and run when this optional extension was not built or RCSIM_NUMPY_CYCLE=1 is set; the results
 * are theirs bit for bit (tests/spacecraft/test_cycle_kernel.py).  The build passes
 * -ffp-contract=off so the compiler never fuses a multiply and an add.
 *
 * What stays in numpy, on purpose: the norms (numpy's einsum sums three squares in an order of
 * its own, (x^2 + z^2) + y^2 on this build) and arctan2 (numpy's vectorised arctan2 rounds
 * differently from the C library's in about one case in 200).
 *
 * Arrays come in through the buffer protocol, C-contiguous, float64 (int64 counters, uint8
 * flags); the Python wrapper makes sure of that. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

PyMODINIT_FUNC PyInit__cycle_kernel(void);

/* np.minimum: a NaN in either operand is the result; otherwise the smaller. */
static inline double np_min(double a, double b) { return (a < b || isnan(a)) ? a : b; }

/* navigation.quat_mul(quat_conj(q_cmd), q), then rotvec_from_quat up to the norm:
 * w_out = minimum(sign * p0, 1), vec_out = sign * p[1:], sign = -1 where p0 < 0.
 * q_cmd has one row per run (step_cmd = 4) or one row for all (step_cmd = 0). */
static PyObject *nav_product(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer q_b, qc_b, w_b, v_b;
    Py_ssize_t n, step_cmd;
    if (!PyArg_ParseTuple(args, "nny*y*w*w*", &n, &step_cmd, &q_b, &qc_b, &w_b, &v_b)) return NULL;
    const double *q = q_b.buf, *qc = qc_b.buf;
    double *w_out = w_b.buf, *v_out = v_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t i = 0; i < n; i++) {
        const double *b = q + 4 * i, *c = qc + step_cmd * i;
        /* quat_conj: q * [1, -1, -1, -1] (exact) */
        double aw = c[0] * 1.0, ax = c[1] * -1.0, ay = c[2] * -1.0, az = c[3] * -1.0;
        double bw = b[0], bx = b[1], by = b[2], bz = b[3];
        double p0 = aw * bw - ax * bx - ay * by - az * bz;
        double p1 = aw * bx + ax * bw + ay * bz - az * by;
        double p2 = aw * by - ax * bz + ay * bw + az * bx;
        double p3 = aw * bz + ax * by - ay * bx + az * bw;
        double sign = p0 < 0 ? -1.0 : 1.0;
        w_out[i] = np_min(sign * p0, 1.0);
        v_out[3 * i] = sign * p1;
        v_out[3 * i + 1] = sign * p2;
        v_out[3 * i + 2] = sign * p3;
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&q_b);
    PyBuffer_Release(&qc_b);
    PyBuffer_Release(&w_b);
    PyBuffer_Release(&v_b);
    Py_RETURN_NONE;
}

/* rotvec_from_quat after the norm s and atan = arctan2(s, w):
 * angle = 2 atan, k = angle / s (2 where s <= 1e-12), att = k * vec; rate = omega - omega_cmd
 * (omega_cmd one row per run, step_cmd = 3, or one for all, 0). */
static PyObject *nav_finish(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer at_b, s_b, v_b, om_b, oc_b, att_b, rate_b;
    Py_ssize_t n, step_cmd;
    if (!PyArg_ParseTuple(args, "nny*y*y*y*y*w*w*", &n, &step_cmd, &at_b, &s_b, &v_b, &om_b, &oc_b,
                          &att_b, &rate_b))
        return NULL;
    const double *at = at_b.buf, *s = s_b.buf, *v = v_b.buf, *om = om_b.buf, *oc = oc_b.buf;
    double *att = att_b.buf, *rate = rate_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t i = 0; i < n; i++) {
        double angle = 2.0 * at[i];
        double k = s[i] > 1e-12 ? angle / s[i] : 2.0;
        const double *c = oc + step_cmd * i;
        for (int a = 0; a < 3; a++) {
            att[3 * i + a] = k * v[3 * i + a];
            rate[3 * i + a] = om[3 * i + a] - c[a];
        }
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&at_b);
    PyBuffer_Release(&s_b);
    PyBuffer_Release(&v_b);
    PyBuffer_Release(&om_b);
    PyBuffer_Release(&oc_b);
    PyBuffer_Release(&att_b);
    PyBuffer_Release(&rate_b);
    Py_RETURN_NONE;
}

/* Failed runs commanded nothing, then propulsion.apply_valve_limits(account=False), then
 * valves.command_valves, per run and jet.  Returns False when a rising command finds no free
 * valve slot (excluded by ValveTiming.check; the caller raises). */
static PyObject *valves(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer cmd_b, failed_b, oae_b, fir_b, drop_b, was_b, st_b, en_b, d_b, od_b, cd_b, on_b;
    Py_ssize_t n, nj, ns;
    double min_pulse, cycle;
    if (!PyArg_ParseTuple(args, "nnny*y*w*w*w*w*w*w*y*y*y*w*dd", &n, &nj, &ns, &cmd_b, &failed_b,
                          &oae_b, &fir_b, &drop_b, &was_b, &st_b, &en_b, &d_b, &od_b, &cd_b, &on_b,
                          &min_pulse, &cycle))
        return NULL;
    const double *cmd = cmd_b.buf, *d = d_b.buf, *od = od_b.buf, *cd = cd_b.buf;
    const uint8_t *failed = failed_b.buf;
    uint8_t *on_at_end = oae_b.buf, *was_on = was_b.buf;
    int64_t *firings = fir_b.buf, *dropped = drop_b.buf;
    double *start = st_b.buf, *end = en_b.buf, *on_out = on_b.buf;
    int ok = 1, any_falling = 0;
    const double full_at = cycle * (1.0 - 1e-12);
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t i = 0; i < n; i++) {
        for (Py_ssize_t j = 0; j < nj; j++) {
            Py_ssize_t e = i * nj + j;
            /* np.where(failed, 0, command); np.clip(.., 0, cycle) + 0.0 keeps NaN; NaN -> 0 */
            double on = failed[i] ? 0.0 : cmd[e];
            if (on < 0.0) on = 0.0;
            if (on > cycle) on = cycle;
            on = on + 0.0; /* a -0.0 command is +0.0, as the numpy form makes it */
            if (isnan(on)) on = 0.0;
            int new_firing = (on > 0) && !on_at_end[e];
            int too_short = new_firing && (on < min_pulse);
            if (too_short) on = 0.0;
            dropped[e] += too_short;
            firings[e] += new_firing && !too_short;
            on_at_end[e] = on >= full_at;
            on_out[e] = on;
            /* command_valves */
            int full = on >= full_at;
            int rising = (on > 0) && !was_on[e];
            int falling = !full && (was_on[e] || (on > 0));
            double *s = start + e * ns, *en = end + e * ns;
            if (rising) {
                Py_ssize_t slot = -1;
                for (Py_ssize_t k = 0; k < ns; k++)
                    if (isnan(s[k])) {
                        slot = k;
                        break;
                    }
                if (slot < 0) {
                    ok = 0;
                    slot = 0;
                }
                s[slot] = d[i] + od[e];
                en[slot] = INFINITY;
            }
            if (falling) {
                any_falling = 1;
                double close = d[i] + on + cd[e];
                for (Py_ssize_t k = 0; k < ns; k++)
                    if (isinf(en[k])) en[k] = close;
            }
            was_on[e] = full;
        }
    }
    /* command_valves: once any valve closed, every interval that closes before it opens is
     * dropped (numpy evaluates this over the whole array only when some run fell). */
    if (any_falling) {
        for (Py_ssize_t e = 0; e < n * nj * ns; e++)
            if (end[e] <= start[e]) {
                start[e] = NAN;
                end[e] = NAN;
            }
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&cmd_b);
    PyBuffer_Release(&failed_b);
    PyBuffer_Release(&oae_b);
    PyBuffer_Release(&fir_b);
    PyBuffer_Release(&drop_b);
    PyBuffer_Release(&was_b);
    PyBuffer_Release(&st_b);
    PyBuffer_Release(&en_b);
    PyBuffer_Release(&d_b);
    PyBuffer_Release(&od_b);
    PyBuffer_Release(&cd_b);
    PyBuffer_Release(&on_b);
    return PyBool_FromLong(ok);
}

/* pieces.cycle_pieces' first test: does any run switch a jet inside the cycle?  If none does,
 * on_out[i, j] = jet j on over the whole cycle (any live interval) and True is returned;
 * otherwise False (on_out is then not meaningful). */
static PyObject *uniform_on(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer st_b, en_b, on_b;
    Py_ssize_t n, nj, ns;
    double cycle;
    if (!PyArg_ParseTuple(args, "nnny*y*w*d", &n, &nj, &ns, &st_b, &en_b, &on_b, &cycle)) return NULL;
    const double *start = st_b.buf, *end = en_b.buf;
    uint8_t *on_out = on_b.buf;
    int uniform = 1;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t e = 0; e < n * nj && uniform; e++) {
        uint8_t on = 0;
        for (Py_ssize_t k = 0; k < ns; k++) {
            double s = start[e * ns + k], en = end[e * ns + k];
            int live = (en > s) && (s < cycle) && (en > 0.0); /* NaN compares False */
            if (live && ((s > 0.0) || (en < cycle))) uniform = 0;
            on |= (uint8_t)live;
        }
        on_out[e] = on;
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&st_b);
    PyBuffer_Release(&en_b);
    PyBuffer_Release(&on_b);
    return PyBool_FromLong(uniform);
}

/* A cycle of one piece of length cycle: Pieces.on_time_s() (einsum of one term: length * on),
 * then PropulsionState's on_time_s += delivered and impulse_ns += delivered * thrust. */
static PyObject *account(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer on_b, th_b, ot_b, im_b, dl_b;
    Py_ssize_t m;
    double length;
    if (!PyArg_ParseTuple(args, "ny*y*w*w*w*d", &m, &on_b, &th_b, &ot_b, &im_b, &dl_b, &length))
        return NULL;
    const uint8_t *on = on_b.buf;
    const double *thrust = th_b.buf;
    double *on_time = ot_b.buf, *impulse = im_b.buf, *delivered = dl_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t e = 0; e < m; e++) {
        double dl = 0.0 + length * (on[e] ? 1.0 : 0.0);
        delivered[e] = dl;
        on_time[e] += dl;
        impulse[e] += dl * thrust[e];
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&on_b);
    PyBuffer_Release(&th_b);
    PyBuffer_Release(&ot_b);
    PyBuffer_Release(&im_b);
    PyBuffer_Release(&dl_b);
    Py_RETURN_NONE;
}

/* valves.end_cycle: drop intervals over by the cycle's end (tails included), shift the rest. */
static PyObject *end_cycle(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer st_b, en_b;
    Py_ssize_t m;
    double cycle, tail;
    if (!PyArg_ParseTuple(args, "nw*w*dd", &m, &st_b, &en_b, &cycle, &tail)) return NULL;
    double *start = st_b.buf, *end = en_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t e = 0; e < m; e++) {
        if (end[e] + tail <= cycle) {
            start[e] = NAN;
            end[e] = NAN;
        }
        start[e] -= cycle;
        end[e] -= cycle;
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&st_b);
    PyBuffer_Release(&en_b);
    Py_RETURN_NONE;
}

/* After a physics step: True when every qpos and qvel entry of every run is finite and below
 * 1e300 in magnitude.  Then each run's sum of them (what the numpy form tests for finiteness,
 * rcsim.spacecraft.simulation) is finite whatever the summation order, so the decision is the numpy
 * form's; False sends the caller to the numpy form.  The fields are column blocks of the
 * batch's state rows (row_len numbers per run). */
static PyObject *bounded_state(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer st_b;
    Py_ssize_t n, row_len, off_p, np_, off_v, nv;
    if (!PyArg_ParseTuple(args, "nny*nnnn", &n, &row_len, &st_b, &off_p, &np_, &off_v, &nv))
        return NULL;
    const double *state = st_b.buf;
    int ok = 1;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t i = 0; i < n && ok; i++) {
        const double *row = state + i * row_len;
        for (Py_ssize_t k = 0; k < np_; k++)
            if (!(fabs(row[off_p + k]) < 1e300)) ok = 0; /* NaN compares False */
        for (Py_ssize_t k = 0; k < nv; k++)
            if (!(fabs(row[off_v + k]) < 1e300)) ok = 0;
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&st_b);
    return PyBool_FromLong(ok);
}

/* Per cycle, each jet group's on-time summed over the chosen runs, and how many of those runs
 * fire a jet of the group: the envelope's two jet columns (rcsim/analysis/engine/campaign/chunk.py),
 * read from the cycle-major record in place.  The numpy form gathers the runs run-major and a
 * group's jets with advanced indexing, which lays the gathered array out jet by jet, so numpy
 * adds, for each cycle, jet after jet and within a jet run after run, from 0.0; the same order
 * here (tests/analysis/engine/campaign/test_campaign_tables.py checks it on both pinned numpys).
 * record (n_cycles, n_total, n_jets); runs (n_runs,) indices; groups (n_groups, n_jets) flags;
 * sums and firing (n_groups, n_cycles). */
static PyObject *group_on_time(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer rec_b, runs_b, grp_b, sum_b, fire_b;
    Py_ssize_t n_cycles, n_total, n_jets, n_runs, n_groups;
    if (!PyArg_ParseTuple(args, "nnnnny*y*y*w*w*", &n_cycles, &n_total, &n_jets, &n_runs,
                          &n_groups, &rec_b, &runs_b, &grp_b, &sum_b, &fire_b))
        return NULL;
    const double *rec = rec_b.buf;
    const int64_t *runs = runs_b.buf;
    const uint8_t *groups = grp_b.buf;
    double *sums = sum_b.buf;
    int64_t *firing = fire_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t k = 0; k < n_cycles; k++) {
        const double *row = rec + k * n_total * n_jets;
        for (Py_ssize_t g = 0; g < n_groups; g++) {
            const uint8_t *in_group = groups + g * n_jets;
            double acc = 0.0;
            for (Py_ssize_t j = 0; j < n_jets; j++) {
                if (!in_group[j]) continue;
                for (Py_ssize_t r = 0; r < n_runs; r++) acc += row[runs[r] * n_jets + j];
            }
            int64_t count = 0;
            for (Py_ssize_t r = 0; r < n_runs; r++) {
                const double *on = row + runs[r] * n_jets;
                for (Py_ssize_t j = 0; j < n_jets; j++) {
                    if (in_group[j] && on[j] > 0) {
                        count++;
                        break;
                    }
                }
            }
            sums[g * n_cycles + k] = acc;
            firing[g * n_cycles + k] = count;
        }
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&rec_b);
    PyBuffer_Release(&runs_b);
    PyBuffer_Release(&grp_b);
    PyBuffer_Release(&sum_b);
    PyBuffer_Release(&fire_b);
    Py_RETURN_NONE;
}

/* Per cycle, run and jet group: a firing of the group's jets starts (some jet on that was not
 * on for the whole previous cycle), and one goes on (some jet on the whole previous cycle and
 * on again), from the cycle-major on-time record; rcsim/analysis/engine/campaign/outcomes.py's
 * axis_firings, whose rule this is jet by jet (booleans: nothing to round).
 * record (n_cycles, n_runs, n_jets); groups (n_groups, n_jets) flags; starts (n_cycles,
 * n_runs, n_groups) and going_on (n_cycles - 1, n_runs, n_groups) flags out. */
static PyObject *group_firings(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer rec_b, grp_b, st_b, go_b;
    Py_ssize_t n_cycles, n_runs, n_jets, n_groups;
    double full_at;
    if (!PyArg_ParseTuple(args, "nnnny*y*w*w*d", &n_cycles, &n_runs, &n_jets, &n_groups, &rec_b,
                          &grp_b, &st_b, &go_b, &full_at))
        return NULL;
    const double *rec = rec_b.buf;
    const uint8_t *groups = grp_b.buf;
    uint8_t *starts = st_b.buf, *going = go_b.buf;
    Py_BEGIN_ALLOW_THREADS;
    for (Py_ssize_t k = 0; k < n_cycles; k++) {
        for (Py_ssize_t i = 0; i < n_runs; i++) {
            const double *on = rec + (k * n_runs + i) * n_jets;
            const double *prev = k > 0 ? on - n_runs * n_jets : NULL;
            for (Py_ssize_t g = 0; g < n_groups; g++) {
                const uint8_t *in_group = groups + g * n_jets;
                uint8_t start = 0, go = 0;
                for (Py_ssize_t j = 0; j < n_jets; j++) {
                    if (!in_group[j] || !(on[j] > 0)) continue;
                    if (prev != NULL && prev[j] >= full_at)
                        go = 1;
                    else
                        start = 1;
                }
                starts[(k * n_runs + i) * n_groups + g] = start;
                if (k > 0) going[((k - 1) * n_runs + i) * n_groups + g] = go;
            }
        }
    }
    Py_END_ALLOW_THREADS;
    PyBuffer_Release(&rec_b);
    PyBuffer_Release(&grp_b);
    PyBuffer_Release(&st_b);
    PyBuffer_Release(&go_b);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"nav_product", nav_product, METH_VARARGS, "Navigation: q_cmd^-1 q, sign, w, vec."},
    {"nav_finish", nav_finish, METH_VARARGS, "Navigation: rotation vector and rate error."},
    {"valves", valves, METH_VARARGS, "Valve limits and valve commands of one cycle."},
    {"uniform_on", uniform_on, METH_VARARGS, "Whether no run switches a jet in the cycle."},
    {"account", account, METH_VARARGS, "Delivered on-time and propulsion totals."},
    {"end_cycle", end_cycle, METH_VARARGS, "Drop finished intervals, shift the rest."},
    {"bounded_state", bounded_state, METH_VARARGS, "Every qpos, qvel entry finite, < 1e300."},
    {"group_on_time", group_on_time, METH_VARARGS, "Per cycle: a jet group's on-time, firing."},
    {"group_firings", group_firings, METH_VARARGS, "Per cycle and run: firings start, go on."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_cycle_kernel",
    "The closed loop's per-cycle bookkeeping, compiled (rcsim/spacecraft/cycle_kernel.py).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__cycle_kernel(void) {
    PyObject *m = PyModule_Create(&module);
#ifdef RCSIM_SOURCE_SHA256
    /* The digest of the source this module was built from: a module older than its source
       (an editable install not rebuilt after a pull) is not used (optional_kernel.py). */
    if (m != NULL && PyModule_AddStringConstant(m, "source_sha256", RCSIM_SOURCE_SHA256) < 0) {
        Py_DECREF(m);
        return NULL;
    }
#endif
    return m;
}
