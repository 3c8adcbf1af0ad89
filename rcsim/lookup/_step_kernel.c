/* One control cycle of the pattern-recognition lookup controller, compiled
 * (rcsim/lookup/pattern_recognition.py, LookupController.step_detail; rcsim/lookup/step_kernel.py).
 *
 * The numpy form in step_detail is the reference: it reads as the paper's logic, and it is
 * what runs when this optional extension was not built (no C compiler at install).  This
 * kernel does the same arithmetic, operation for operation and in the same order, run by
 * run: about 45 numpy calls per cycle on (n_runs, n_jets) arrays become one pass.  The
 * results are bit for bit the numpy form's (tests/lookup/test_step_kernel.py); the build
 * passes -ffp-contract=off so the compiler never fuses a multiply and an add.
 *
 * Arrays come in through the buffer protocol, C-contiguous, float64 (int64 for indices,
 * uint8 for flags); the Python wrapper (rcsim/lookup/step_kernel.py) makes sure of that. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

PyMODINIT_FUNC PyInit__step_kernel(void);

#define N_AXES 3
#define N_GROUPS (2 * N_AXES + 1)

/* np.minimum / np.maximum: a NaN in either operand is the result. */
static inline double np_min(double a, double b) { return (a < b || isnan(a)) ? a : b; }
static inline double np_max(double a, double b) { return (a > b || isnan(a)) ? a : b; }

static inline int64_t np_sign_int(double x) { return (x > 0.0) - (x < 0.0); }

static PyObject *step(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer att, theta_b, rate, rem_in, hold_in, man_in, times, scale_in, code_map, rate_abs, axis_b, group_b,
        opp_b, on_b, rem_b, hold_b, case_b, need_b, new_b, done_b;
    Py_ssize_t n, n_jets, n_cases;
    int times_per_run, has_scale;
    double maneuver_limit, maneuver_rate, rate_limit, no_fire_band, on_limit, cycle, hold_time,
        timer_eps;
    if (!PyArg_ParseTuple(
            args, "nnnipy*y*y*y*y*y*y*y*y*y*y*y*y*w*w*w*w*w*w*w*dddddddd", &n, &n_jets, &n_cases,
            &times_per_run, &has_scale, &att, &theta_b, &rate, &rem_in, &hold_in, &man_in, &times,
            &scale_in,
            &code_map, &rate_abs, &axis_b, &group_b, &opp_b, &on_b, &rem_b, &hold_b, &case_b,
            &need_b, &new_b, &done_b, &maneuver_limit, &maneuver_rate, &rate_limit,
            &no_fire_band, &on_limit, &cycle, &hold_time, &timer_eps))
        return NULL;

    const double *e_all = att.buf, *theta_all = theta_b.buf, *w_all = rate.buf, *rem0 = rem_in.buf, *hold0 = hold_in.buf;
    const uint8_t *man_all = man_in.buf;
    const double *tab = times.buf, *cscale = scale_in.buf, *rabs = rate_abs.buf;
    const int64_t *case_of_code = code_map.buf, *axis = axis_b.buf, *group = group_b.buf,
                  *opp = opp_b.buf;
    double *on_all = on_b.buf, *rem_all = rem_b.buf, *hold_all = hold_b.buf,
           *need_all = need_b.buf;
    int64_t *case_all = case_b.buf;
    uint8_t *new_all = new_b.buf, *done_all = done_b.buf;

    int ok;
    Py_BEGIN_ALLOW_THREADS;
    double *rem = (double *)malloc(sizeof(double) * (size_t)(n_jets > 0 ? n_jets : 1));
    uint8_t *fire = (uint8_t *)malloc((size_t)(n_jets > 0 ? n_jets : 1));
    for (Py_ssize_t i = 0; rem && fire && i < n; i++) {
        const double *e = e_all + 3 * i, *w = w_all + 3 * i;
        /* Steps 1-2: rate error with the maneuver term, dead band.  theta = |e| comes from
         * the caller: numpy's einsum sums the three squares in an order of its own; so does
         * the maneuver flag (the hysteresis is the caller's: it needs the last cycle's). */
        double theta = theta_all[i];
        int maneuver = man_all[i] != 0;
        double div = theta > 0.0 ? theta : 1.0;
        double need[N_AXES];
        int any_err = 0;
        int64_t code = 0;
        static const int64_t weight[N_AXES] = {9, 3, 1};
        for (int a = 0; a < N_AXES; a++) {
            double err = w[a] + (maneuver ? maneuver_rate * (e[a] / div) : 0.0);
            err = fabs(err) < rate_limit ? 0.0 : err;
            need[a] = -err;
            code += (np_sign_int(need[a]) + 1) * weight[a];
            any_err |= need[a] != 0.0;
            need_all[3 * i + a] = need[a];
        }
        /* Step 3: the case of the sign pattern (code 0 = (-,-,-), a valid row). */
        int64_t c = case_of_code[any_err ? code : 0];
        case_all[i] = c;
        /* Step 4: the fraction of the case's rate each axis needs. */
        double scale[N_AXES];
        for (int a = 0; a < N_AXES; a++) {
            double denom = rabs[3 * c + a];
            scale[a] = denom > 0.0 ? fabs(need[a]) / denom : 0.0;
        }
        const double *row = tab + (times_per_run ? (i * n_cases + c) * n_jets : c * n_jets);
        const double *cs = has_scale ? cscale + (i * n_cases + c) * N_AXES : NULL;
        /* Step 5: gates.  The largest remaining on-time of each (axis, sign) group. */
        const double *r0 = rem0 + i * n_jets;
        double gmax[N_GROUPS] = {0.0};
        int seen[N_GROUPS] = {0};
        for (Py_ssize_t j = 0; j < n_jets; j++) {
            if (axis[j] < 0) continue;
            int64_t g = group[j];
            gmax[g] = seen[g] ? np_max(r0[j], gmax[g]) : r0[j];
            seen[g] = 1;
        }
        int no_fire = fabs(theta - maneuver_limit) < no_fire_band;
        const double *h0 = hold0 + 3 * i;
        int axis_new[N_AXES] = {0, 0, 0};
        double *newt = rem; /* scratch: the new firing times, then the re-planned remainders */
        for (Py_ssize_t j = 0; j < n_jets; j++) {
            int64_t a = axis[j];
            double jet_scale = a >= 0 ? scale[a] : 0.0;
            double t = row[j];
            if (cs != NULL) t = t * (a >= 0 ? cs[a] : 0.0);
            double nt = any_err ? t * jet_scale : 0.0;
            double hold_jet = a >= 0 ? h0[a] : 0.0;
            int gate = (r0[j] < on_limit) && (gmax[opp[j]] < on_limit) &&
                       (hold_jet <= timer_eps) && !no_fire;
            fire[j] = gate && (nt > 0.0);
            if (fire[j] && a >= 0) axis_new[a] = 1;
            newt[j] = nt;
        }
        /* An axis with a new firing is re-planned; step 7: delivery and hold timers. */
        double *on = on_all + i * n_jets, *rn = rem_all + i * n_jets;
        int fired[N_AXES] = {0, 0, 0}, left[N_AXES] = {0, 0, 0};
        for (Py_ssize_t j = 0; j < n_jets; j++) {
            int64_t a = axis[j];
            int replan = a >= 0 && axis_new[a];
            double r = replan ? (fire[j] ? newt[j] : 0.0) : r0[j];
            on[j] = np_min(r, cycle);
            rn[j] = np_max(r - cycle, 0.0);
            if (a >= 0) {
                fired[a] |= on[j] != 0.0;
                left[a] |= rn[j] > 0.0;
            }
        }
        for (int a = 0; a < N_AXES; a++) {
            int done = fired[a] && !left[a];
            hold_all[3 * i + a] = done ? hold_time : np_max(h0[a] - cycle, 0.0);
            new_all[3 * i + a] = (uint8_t)axis_new[a];
            done_all[3 * i + a] = (uint8_t)done;
        }
    }
    ok = rem != NULL && fire != NULL;
    free(rem);
    free(fire);
    Py_END_ALLOW_THREADS;

    PyBuffer_Release(&att);
    PyBuffer_Release(&theta_b);
    PyBuffer_Release(&rate);
    PyBuffer_Release(&rem_in);
    PyBuffer_Release(&hold_in);
    PyBuffer_Release(&man_in);
    PyBuffer_Release(&times);
    PyBuffer_Release(&scale_in);
    PyBuffer_Release(&code_map);
    PyBuffer_Release(&rate_abs);
    PyBuffer_Release(&axis_b);
    PyBuffer_Release(&group_b);
    PyBuffer_Release(&opp_b);
    PyBuffer_Release(&on_b);
    PyBuffer_Release(&rem_b);
    PyBuffer_Release(&hold_b);
    PyBuffer_Release(&case_b);
    PyBuffer_Release(&need_b);
    PyBuffer_Release(&new_b);
    PyBuffer_Release(&done_b);
    if (!ok) return PyErr_NoMemory();
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"step", step, METH_VARARGS, "One lookup-controller cycle over every run (in place)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_step_kernel",
    "The lookup controller's cycle, compiled (rcsim/lookup/step_kernel.py).", -1, methods,
};

PyMODINIT_FUNC PyInit__step_kernel(void) {
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
