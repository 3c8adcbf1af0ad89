/* A clock that always reads zero, for MuJoCo's timer callback (rcsim/spacecraft/mujoco_timers.py).
 *
 * With no callback installed, MuJoCo 4 times every stage of every step with the system clock
 * (about 90 clock reads per RK4 step, a fifth of this vehicle's step).  rcsim never reads those
 * timers; a native function is needed because MuJoCo calls it from its own threads, without
 * the interpreter.  Built as an optional extension: without a C compiler rcsim still installs
 * and runs, with MuJoCo's default timers. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

PyMODINIT_FUNC PyInit__zero_clock(void);

double rcsim_zero_clock(void) { return 0.0; }

static PyObject *address(PyObject *self, PyObject *unused) {
    (void)self;
    (void)unused;
    return PyLong_FromVoidPtr((void *)&rcsim_zero_clock);
}

static PyMethodDef methods[] = {
    {"address", address, METH_NOARGS, "Address of double rcsim_zero_clock(void)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_zero_clock",
    "A clock that reads zero, for mujoco.set_mjcb_time.", -1, methods,
};

PyMODINIT_FUNC PyInit__zero_clock(void) {
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
