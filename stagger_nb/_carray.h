/* What the C extensions of stagger_nb (io/_cparse.c, staggered/_cspline.c, timewarp/_cdp.c) share: taking an
   argument's buffer only when it holds what the function indexes, and the module object with its init function
   (included by each; each is built from its one .c file). */
#ifndef STAGGER_NB_CARRAY_H
#define STAGGER_NB_CARRAY_H
#include <Python.h>

/* The buffer of ``obj``: C-contiguous, writable when asked, of 8-byte items of kind 'f' (float64) or 'i'
   (int64), native byte order. 0, or -1 with a TypeError naming ``name`` (a float32 array or a bytes object of the
   right length would otherwise be read as other values). */
static inline int get_array(PyObject *obj, Py_buffer *view, int writable, char kind, const char *name)
{
    int flags = PyBUF_FORMAT | PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    const char *f = NULL;
    if (PyObject_GetBuffer(obj, view, flags) == 0) {
        f = view->format ? view->format : "B";
        if (*f == '=' || *f == '@' || (*f == '<' && PY_LITTLE_ENDIAN)) ++f;
        if (view->itemsize == 8 && f[0] != '\0' && f[1] == '\0' &&
            (kind == 'f' ? f[0] == 'd' : (f[0] == 'q' || f[0] == 'l')))
            return 0;
        PyBuffer_Release(view);
    }
    PyErr_Clear();
    PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous%s %s array", name, writable ? " writable" : "",
                 kind == 'f' ? "float64" : "int64");
    return -1;
}

/* a * b into *r when it fits a Py_ssize_t (a, b >= 0); 0 when it would overflow */
static inline int mul_ok(Py_ssize_t a, Py_ssize_t b, Py_ssize_t *r)
{
    if (a < 0 || b < 0 || (b != 0 && a > PY_SSIZE_T_MAX / b)) return 0;
    *r = a * b;
    return 1;
}

/* The extension module ``name`` (an identifier: _cparse, _cspline, _cdp) with the docstring ``doc`` and the
   method table ``methods`` (each entry's docstring a PyDoc_STRVAR beside its function), and its init function. */
#define SN_MODULE(name, doc, methods)                                                                                \
    static struct PyModuleDef name##_module = {PyModuleDef_HEAD_INIT, #name, doc, -1, methods, NULL, NULL, NULL, \
                                               NULL};                                                             \
    PyMODINIT_FUNC PyInit_##name(void) { return PyModule_Create(&name##_module); }

#endif
