/* Optional C accelerator of the forward pass of guided time warping's constrained shortest path
 * (stagger_nb/timewarp/dp.py, constrained_dp; Hsu et al. 2007, eqs. 3-4).
 *
 * Per output frame q it computes, for every next step b and middle frame j of the band,
 * best[b, j] = min_a c[a, j] + f(j - a, j, j + b) and the minimising a (the largest on exact ties, as the numpy
 * path's backpointers and its re-derivation while backtracking choose), then the next output frame's costs
 * c'[b, k] = best[b, k - b] (inf outside the band). The same additions on the same doubles as numpy's
 * np.add + np.minimum.reduce (built with -ffp-contract=off), so the same minima and the same frames, in one
 * loop per (a, b) row instead of an (s, s, band) temporary per output frame; the GIL is released meanwhile.
 * Scores must hold no NaN (the caller checks: numpy's minimum propagates NaN, this loop would skip it).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../_carray.h" /* get_array, mul_ok: arguments checked before they are indexed */

/* GCC/Clang vector extensions (SSE2 on x86-64, NEON on arm64): a compare gives all-ones lanes */
typedef double v2d __attribute__((vector_size(16)));
typedef int64_t v2i __attribute__((vector_size(16)));
#define TILE 128 /* middle frames per tile */

static int get_int8(PyObject *obj, Py_buffer *view, const char *name)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_FORMAT | PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) == 0) {
        const char *f = view->format ? view->format : "B";
        if (*f == '=' || *f == '@' || *f == '<' || *f == '>' || *f == '|') ++f;
        if (view->itemsize == 1 && f[0] == 'b' && f[1] == '\0') return 0;
        PyBuffer_Release(view);
    }
    PyErr_Clear();
    PyErr_Format(PyExc_TypeError, "%s must be a C-contiguous writable int8 array", name);
    return -1;
}

/* the output frames q0 .. q1 - 1 of the recurrence; see forward's docstring. ``best`` and ``which`` are (s, wmax)
 * scratch rows: the running minimum and its a - 1 (as a double, so the compare-and-select loop vectorises) */
static void run(const double *S, Py_ssize_t n, Py_ssize_t s, const int64_t *lo, const int64_t *hi, Py_ssize_t q0,
                Py_ssize_t q1, double *cur, Py_ssize_t wmax, int8_t *back, const int64_t *off, double *best,
                double *which)
{
    for (Py_ssize_t q = q0; q < q1; ++q) {
        const Py_ssize_t l0 = (Py_ssize_t)lo[q], L = (Py_ssize_t)(hi[q] - lo[q]) + 1;
        const Py_ssize_t n0 = (Py_ssize_t)lo[q + 1], L2 = (Py_ssize_t)(hi[q + 1] - lo[q + 1]) + 1;
        for (Py_ssize_t t0 = 0; t0 < L; t0 += TILE) { /* columns in tiles: best, which and cur stay in L1 */
            const Py_ssize_t t1 = t0 + TILE < L ? t0 + TILE : L;
            for (Py_ssize_t b = 0; b < s; ++b) { /* a = 1 (row 0) */
                const double *Sr = S + b * n + l0;
                double *br = best + b * L, *wr = which + b * L;
                for (Py_ssize_t j = t0; j < t1; ++j) {
                    br[j] = cur[j] + Sr[j];
                    wr[j] = 0.0;
                }
            }
            for (Py_ssize_t a = 1; a < s; ++a) {
                const double *ca = cur + a * wmax;
                const double av = (double)a;
                const v2d av2 = {av, av};
                const v2i avv = (v2i)av2;
                for (Py_ssize_t b = 0; b < s; ++b) {
                    const double *Sr = S + (a * s + b) * n + l0;
                    double *br = best + b * L, *wr = which + b * L;
                    Py_ssize_t j = t0;
                    for (; j + 2 <= t1; j += 2) { /* two at a time, selected by bit masks (no branch) */
                        v2d x, y, o, w;
                        memcpy(&x, ca + j, sizeof x);
                        memcpy(&y, Sr + j, sizeof y);
                        memcpy(&o, br + j, sizeof o);
                        memcpy(&w, wr + j, sizeof w);
                        const v2d v = x + y;
                        const v2i le = v <= o; /* all ones where v <= o: the largest minimising a on ties */
                        const v2i nb = ((v2i)v & le) | ((v2i)o & ~le), nw = (avv & le) | ((v2i)w & ~le);
                        memcpy(br + j, &nb, sizeof nb);
                        memcpy(wr + j, &nw, sizeof nw);
                    }
                    for (; j < t1; ++j) {
                        const double v = ca[j] + Sr[j];
                        if (v <= br[j]) {
                            br[j] = v;
                            wr[j] = av;
                        }
                    }
                }
            }
        }
        int8_t *arg = back + off[q];
        for (Py_ssize_t i = 0; i < s * L; ++i) arg[i] = (int8_t)which[i];
        /* c'[b, kk] = best[b, j] with j = n0 + kk - (b + 1) - l0 (the pair (j, j + b + 1)), inf outside */
        for (Py_ssize_t b = 0; b < s; ++b) {
            double *cb = cur + b * wmax;
            const double *br = best + b * L;
            for (Py_ssize_t kk = 0; kk < L2; ++kk) {
                const Py_ssize_t jj = n0 + kk - b - 1 - l0;
                cb[kk] = (jj >= 0 && jj < L) ? br[jj] : INFINITY;
            }
        }
    }
}

PyDoc_STRVAR(forward_doc,
     "forward(Sab, n, s, lo, hi, q0, q1, cur, wmax, back, offsets)\n\n"
     "Output frames q0 .. q1 - 1 of constrained_dp's recurrence. Sab (s, s, n) float64: Sab[a-1, b-1, j] =\n"
     "f(j - a, j, j + b); lo, hi (m,) int64 the band; cur (s, wmax) float64: on entry row a-1 holds the costs\n"
     "of output frame q0 (columns k - lo[q0]), on return those of q1; back int8: the minimising a - 1 of step q\n"
     "as an (s, hi[q] - lo[q] + 1) block at offsets[q] (int64, (m,)).");

static PyObject *forward(PyObject *self, PyObject *args)
{
    PyObject *oS, *olo, *ohi, *ocur, *oback, *ooff;
    Py_ssize_t n, s, q0, q1, wmax;
    if (!PyArg_ParseTuple(args, "OnnOOnnOnOO", &oS, &n, &s, &olo, &ohi, &q0, &q1, &ocur, &wmax, &oback, &ooff))
        return NULL;
    Py_buffer vS = {0}, vlo = {0}, vhi = {0}, vcur = {0}, vback = {0}, voff = {0};
    PyObject *result = NULL;
    double *best = NULL;
    if (get_array(oS, &vS, 0, 'f', "scores") || get_array(olo, &vlo, 0, 'i', "lo") ||
        get_array(ohi, &vhi, 0, 'i', "hi") || get_array(ocur, &vcur, 1, 'f', "cur") ||
        get_int8(oback, &vback, "back") || get_array(ooff, &voff, 0, 'i', "offsets"))
        goto done;
    Py_ssize_t ss, need, m = vlo.len / 8, bs;
    if (s < 1 || s > 127 || n < 2 || wmax < 1 || !mul_ok(s, s, &ss) || !mul_ok(ss, n, &need) ||
        vS.len / 8 != need || vhi.len / 8 != m || voff.len / 8 != m || q0 < 0 || q1 > m - 1 || q0 > q1 ||
        !mul_ok(s, wmax, &need) || vcur.len / 8 < need || !mul_ok(s, wmax, &bs)) {
        PyErr_SetString(PyExc_ValueError, "forward: inconsistent sizes");
        goto done;
    }
    const int64_t *lo = (const int64_t *)vlo.buf, *hi = (const int64_t *)vhi.buf, *off = (const int64_t *)voff.buf;
    for (Py_ssize_t q = q0; q < q1; ++q) { /* every index the loop takes, checked before it runs */
        if (lo[q] < 0 || hi[q] >= n || lo[q + 1] < 0 || hi[q + 1] >= n || hi[q] < lo[q] || hi[q + 1] < lo[q + 1] ||
            hi[q] - lo[q] >= wmax || hi[q + 1] - lo[q + 1] >= wmax || off[q] < 0 || off[q] > (int64_t)vback.len ||
            ((int64_t)vback.len - off[q]) / s < hi[q] - lo[q] + 1) {
            PyErr_Format(PyExc_ValueError, "forward: the band of output frame %zd does not fit", q);
            goto done;
        }
    }
    best = (double *)malloc(2 * (size_t)bs * sizeof(double));
    if (best == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    run((const double *)vS.buf, n, s, lo, hi, q0, q1, (double *)vcur.buf, wmax, (int8_t *)vback.buf, off, best,
        best + bs);
    Py_END_ALLOW_THREADS
    result = Py_None;
    Py_INCREF(result);
done:
    free(best);
    if (vS.obj) PyBuffer_Release(&vS);
    if (vlo.obj) PyBuffer_Release(&vlo);
    if (vhi.obj) PyBuffer_Release(&vhi);
    if (vcur.obj) PyBuffer_Release(&vcur);
    if (vback.obj) PyBuffer_Release(&vback);
    if (voff.obj) PyBuffer_Release(&voff);
    return result;
}

static PyMethodDef methods[] = {
    {"forward", forward, METH_VARARGS, forward_doc},
    {NULL, NULL, 0, NULL}};

SN_MODULE(_cdp, "C kernel of constrained_dp's forward pass (see _cdp.c).", methods)
