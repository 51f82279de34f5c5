/* Optional C accelerator of evaluate()'s inner kernel (stagger_nb/staggered/evaluation.py,
 * _rotations_block): per (segment, joint) sample, the quaternion Bezier of its pair's controls by recursive
 * slerp (Appendix A of Coleman 2008) times exp of the linearly interpolated displacement rotation vector.
 *
 * It performs the numpy kernels' operations (_kernels.py: arc_into, slerp_into, sin_poly, qexp_into,
 * qmul_into) in the same order on the same doubles, one loop per numpy pass group instead of one full-length
 * temporary per operation, so the results are bit for bit those of the numpy path (built with
 * -ffp-contract=off: no fused multiply-adds). Like sin_poly, each level's polynomial degree is chosen from the
 * largest argument of the whole block, hence one loop per level; the arc angles between levels are numpy's
 * arccos, called by the Python caller between four stages (numpy's SIMD arccos and libm's acos differ in the
 * last bit of ~9 % of arguments).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>

#include "../_carray.h" /* get_array, mul_ok: arguments checked before they are indexed */

#define MIN_ARC 1e-8

typedef struct {
    const double *taylor; /* sin Taylor coefficients x, x^3, ... (10) */
    const double *limits; /* _TERM_LIMITS (9) */
} poly_t;

static int terms_for(const poly_t *P, double xmax)
{
    int n = 0; /* bisect_right(limits, xmax) + 1 */
    while (n < 9 && P->limits[n] <= xmax) ++n;
    return n + 1;
}

static inline double sin_poly1(const poly_t *P, int n, double x)
{
    double z = x * x, o = P->taylor[n - 1];
    for (int k = n - 2; k >= 0; --k) {
        o *= z;
        o += P->taylor[k];
    }
    return o * x;
}

static inline double np_max(double a, double b) { return (a >= b || isnan(a)) ? a : b; }
static inline double np_min(double a, double b) { return (a <= b || isnan(a)) ? a : b; }

/* arc_into of a -> b ((4, n) rows with row stride n), first half: sg = the dot, ct = min(|dot|, 1); the caller
 * then writes th = arccos(ct) with numpy's arccos (its SIMD arccos differs from libm's acos in the last bit
 * of ~9 % of arguments: numpy's own keeps the numpy path's bits) */
static void arc_pre(const double *a, const double *b, Py_ssize_t n, double *sg, double *ct)
{
    for (Py_ssize_t i = 0; i < n; ++i) {
        double d = a[i] * b[i];
        d += a[n + i] * b[n + i];
        d += a[2 * n + i] * b[2 * n + i];
        d += a[3 * n + i] * b[3 * n + i];
        sg[i] = d;
        ct[i] = np_min(fabs(d), 1.0);
    }
}

/* second half: th = max(th, MIN_ARC), sg = sign(dot) / sin th, ct = cos th / sin th */
static void arc_post(const poly_t *P, Py_ssize_t n, double *sg, double *th, double *ct)
{
    double tmax = 0.0, tmin = 0.0;
    for (Py_ssize_t i = 0; i < n; ++i) {
        double t = np_max(th[i], MIN_ARC);
        th[i] = t;
        if (i == 0 || t > tmax) tmax = t;
        if (i == 0 || t < tmin) tmin = t;
    }
    int m = terms_for(P, tmax > -tmin ? tmax : -tmin);
    for (Py_ssize_t i = 0; i < n; ++i) {
        double inv = 1.0 / sin_poly1(P, m, th[i]);
        ct[i] *= inv;
        sg[i] = copysign(inv, sg[i]);
    }
}

/* slerp_into: out (4, n) = a * w0 + b * s; a, b (4, n) with row strides sa, sb; arcs gathered per sample */
static void slerp(const poly_t *P, const double *a, Py_ssize_t sa, const double *b, Py_ssize_t sb,
                  const double *t, const double *sg, const double *th, const double *ct, Py_ssize_t n, double *out)
{
    double xmax = 0.0, xmin = 0.0;
    for (Py_ssize_t i = 0; i < n; ++i) {
        double x = t[i] * th[i];
        if (i == 0 || x > xmax) xmax = x;
        if (i == 0 || x < xmin) xmin = x;
    }
    int m = terms_for(P, xmax > -xmin ? xmax : -xmin);
    for (Py_ssize_t i = 0; i < n; ++i) {
        double s = sin_poly1(P, m, t[i] * th[i]);
        double w0 = s * s;
        w0 = 1.0 - w0;
        w0 = np_max(w0, 0.0);
        w0 = sqrt(w0);
        w0 -= ct[i] * s;
        s *= sg[i];
        for (int r = 0; r < 4; ++r) {
            double o = a[r * sa + i] * w0;
            o += b[r * sb + i] * s;
            out[r * n + i] = o;
        }
    }
}

static inline double max_abs(const double *x, Py_ssize_t n)
{
    double mx = 0.0, mn = 0.0;
    for (Py_ssize_t i = 0; i < n; ++i) {
        if (i == 0 || x[i] > mx) mx = x[i];
        if (i == 0 || x[i] < mn) mn = x[i];
    }
    return mx > -mn ? mx : -mn;
}

/* qexp_into of the halved displacement rows e (3, n) with |e| = h, then qmul_into(S, exp(e)) into out */
static void exp_mul(const poly_t *P, const double *S, const double *e, double *h, double *x1, double *x2,
                    Py_ssize_t n, double *out, Py_ssize_t so)
{
    double hmax = 0.0;
    for (Py_ssize_t i = 0; i < n; ++i)
        if (i == 0 || h[i] > hmax) hmax = h[i];
    int narrow = n && hmax <= 1.0, m = 1, m1 = 1, m2 = 1;
    if (narrow) {
        m = terms_for(P, hmax);
    } else {  /* _sin_cos_wide: cos h = sin(pi/2 - h), sin h = sin(min(pi - h, h)) */
        for (Py_ssize_t i = 0; i < n; ++i) {
            x1[i] = M_PI / 2 - h[i];
            double r = M_PI - h[i];
            x2[i] = np_min(r, h[i]);
        }
        m1 = terms_for(P, max_abs(x1, n));
        m2 = terms_for(P, max_abs(x2, n));
    }
    for (Py_ssize_t i = 0; i < n; ++i) {
        double hh = h[i], sn, cs;
        if (narrow) {
            sn = sin_poly1(P, m, hh);
            cs = sn * sn;
            cs = 1.0 - cs;
            cs = sqrt(cs);
        } else {
            cs = sin_poly1(P, m1, x1[i]);
            sn = sin_poly1(P, m2, x2[i]);
        }
        double sinc = sn / np_max(hh, 1e-6);
        if (hh < 1e-6) sinc = 1.0 - hh * hh / 6.0;
        double ex = e[i] * sinc, ey = e[n + i] * sinc, ez = e[2 * n + i] * sinc, ew = cs;
        double ax = S[i], ay = S[n + i], az = S[2 * n + i], aw = S[3 * n + i], o;
        o = aw * ex; o += ax * ew; o += ay * ez; o -= az * ey; out[i] = o;
        o = aw * ey; o -= ax * ez; o += ay * ew; o += az * ex; out[so + i] = o;
        o = aw * ez; o += ax * ey; o -= ay * ex; o += az * ew; out[2 * so + i] = o;
        o = aw * ew; o -= ax * ex; o -= ay * ey; o -= az * ez; out[3 * so + i] = o;
    }
}

/* One stage of the block (see the module comment); scratch rows of w: G controls (16) and arcs (9) gathered,
 * A B C D E (20), the arc in progress (3: sg, th, ct; the caller fills th = arccos(ct) between stages),
 * e (3), h, x1, x2. */
static void block(int stage, const poly_t *P, const double *ctrl, const double *arcp, Py_ssize_t np_,
                  const double *table, Py_ssize_t nrows, const int64_t *counts, Py_ssize_t M, const int64_t *idx,
                  const double *t, Py_ssize_t n, double *out, Py_ssize_t so, double *w)
{
    double *G = w, *Ga = w + 16 * n, *A = Ga + 9 * n, *B = A + 4 * n, *C = B + 4 * n, *D = C + 4 * n,
           *E = D + 4 * n, *sg = E + 4 * n, *th = sg + n, *ct = th + n, *e = ct + n, *h = e + 3 * n,
           *x1 = h + n, *x2 = x1 + n;
    switch (stage) {
    case 0:
        for (int r = 0; r < 16; ++r)
            for (Py_ssize_t i = 0; i < n; ++i) G[r * n + i] = ctrl[r * np_ + idx[i]];
        for (int r = 0; r < 9; ++r)
            for (Py_ssize_t i = 0; i < n; ++i) Ga[r * n + i] = arcp[r * np_ + idx[i]];
        slerp(P, G, n, G + 4 * n, n, t, Ga, Ga + n, Ga + 2 * n, n, A);
        slerp(P, G + 4 * n, n, G + 8 * n, n, t, Ga + 3 * n, Ga + 4 * n, Ga + 5 * n, n, B);
        slerp(P, G + 8 * n, n, G + 12 * n, n, t, Ga + 6 * n, Ga + 7 * n, Ga + 8 * n, n, C);
        arc_pre(A, B, n, sg, ct);
        return;
    case 1:
        arc_post(P, n, sg, th, ct);
        slerp(P, A, n, B, n, t, sg, th, ct, n, D);
        arc_pre(B, C, n, sg, ct);
        return;
    case 2:
        arc_post(P, n, sg, th, ct);
        slerp(P, B, n, C, n, t, sg, th, ct, n, E);
        arc_pre(D, E, n, sg, ct);
        return;
    default:
        break;
    }
    arc_post(P, n, sg, th, ct);
    double *S = A; /* the spline */
    slerp(P, D, n, E, n, t, sg, th, ct, n, S);
    if (M == 0) { /* the spline alone, renormalised (bezier_into's normalize=True) */
        for (Py_ssize_t i = 0; i < n; ++i) {
            double q = S[i] * S[i];
            q += S[n + i] * S[n + i];
            q += S[2 * n + i] * S[2 * n + i];
            q += S[3 * n + i] * S[3 * n + i];
            q = sqrt(q);
            for (int r = 0; r < 4; ++r) out[r * so + i] = S[r * n + i] / q;
        }
        return;
    }
    /* displacement: linear interpolation of rotation vectors on each pair's uniform grid, halved */
    for (Py_ssize_t i = 0; i < n; ++i) {
        int64_t cnt = counts[idx[i]];
        double u = t[i] * (double)(cnt - 1);
        int64_t m0 = (int64_t)u;
        if (m0 > cnt - 2) m0 = cnt - 2;
        double fa = u - (double)m0;
        int64_t row = m0 + idx[i] * M;
        double hh = 0.0;
        for (int r = 0; r < 3; ++r) {
            double d0 = table[r * nrows + row], d1 = table[r * nrows + row + 1];
            d1 -= d0;
            d1 *= fa;
            d0 += d1;
            d0 *= 0.5;
            e[r * n + i] = d0;
            if (r == 0) hh = d0 * d0;
            else hh += d0 * d0;
        }
        h[i] = np_min(sqrt(hh), M_PI);
    }
    exp_mul(P, S, e, h, x1, x2, n, out, so);
}

#define SCRATCH_ROWS 56

PyDoc_STRVAR(rotations_block_doc,
     "rotations_block(stage, ctrl, arcp, table, counts, M, idx, t, out, so, work, taylor, limits)\n\n"
     "Stage 0..3 of evaluation._rotations_block into out (4 rows of stride so); between stages the\n"
     "caller writes work row 46 (theta) = numpy.arccos(work row 47) (see _kernels.rotations_block_c).");

static PyObject *rotations_block(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_buffer ctrl = {0}, arcp = {0}, table = {0}, counts = {0}, idx = {0}, t = {0}, out = {0}, work = {0},
              taylor = {0}, limits = {0};
    PyObject *o[10];
    Py_ssize_t M, so;
    int stage;
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "iOOOOnOOOnOOO", &stage, &o[0], &o[1], &o[2], &o[3], &M, &o[4], &o[5], &o[6], &so,
                          &o[7], &o[8], &o[9]))
        return NULL;
    Py_buffer *views[10] = {&ctrl, &arcp, &table, &counts, &idx, &t, &out, &work, &taylor, &limits};
    static const char *names[10] = {"rotations_block: ctrl", "rotations_block: arcp", "rotations_block: table",
                                    "rotations_block: counts", "rotations_block: idx", "rotations_block: t",
                                    "rotations_block: out", "rotations_block: work", "rotations_block: taylor",
                                    "rotations_block: limits"};
    for (int k = 0; k < 10; ++k)
        if (get_array(o[k], views[k], k == 6 || k == 7, (k == 3 || k == 4) ? 'i' : 'f', names[k]) < 0) goto done;
    Py_ssize_t np_ = ctrl.len / 128, n = t.len / 8, table_len = 0, work_len = 0, out_len = 0;
    /* every size the kernel indexes, computed without overflow: (3, P * M) table, 56 n scratch, 4 out rows of
       stride so (the last sample at 3 so + n - 1) */
    int ok = stage >= 0 && stage <= 3 && (M == 0 || M >= 2) && ctrl.len == 128 * np_ && counts.len == 8 * np_ &&
             arcp.len == 72 * np_ && mul_ok(np_, M, &table_len) && mul_ok(table_len, 24, &table_len) &&
             table.len == table_len && t.len == 8 * n && idx.len == t.len && mul_ok(n, 8 * SCRATCH_ROWS, &work_len) &&
             work.len >= work_len && taylor.len == 80 && limits.len == 72 && so >= n;
    if (ok && n) ok = mul_ok(so, 3, &out_len) && out_len <= PY_SSIZE_T_MAX - n && mul_ok(out_len + n, 8, &out_len) &&
                      out.len >= out_len;
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "rotations_block: stage 0..3, and buffer sizes (16, P), (9, P), (3, P * M), "
                                          "P counts, n idx / t, out rows of stride so >= n, 56 n of scratch (M = 0: "
                                          "no displacement, the spline renormalised; else M >= 2)");
        goto done;
    }
    const int64_t *ix = (const int64_t *)idx.buf, *cn = (const int64_t *)counts.buf;
    const double *tt = (const double *)t.buf;
    for (Py_ssize_t i = 0; i < n; ++i) {
        if (ix[i] < 0 || ix[i] >= np_ || (M && (cn[ix[i]] < 2 || cn[ix[i]] > M))) {
            PyErr_Format(PyExc_ValueError, "rotations_block: sample %zd: pair %lld outside [0, %zd) or its "
                                           "count outside [2, M]", i, (long long)ix[i], np_);
            goto done;
        }
        /* the displacement row index: (int64)(t (count - 1)) must be a valid, non-negative conversion (the
           kernel clamps it above at count - 2); NaN fails both tests */
        double u = tt[i] * (double)(cn[ix[i]] - 1);
        if (M && !(u > -1.0 && u < 4611686018427387904.0)) {
            PyErr_Format(PyExc_ValueError, "rotations_block: sample %zd: t outside the segment (or not finite)", i);
            goto done;
        }
    }
    poly_t P = {(const double *)taylor.buf, (const double *)limits.buf};
    Py_BEGIN_ALLOW_THREADS
    block(stage, &P, (const double *)ctrl.buf, (const double *)arcp.buf, np_, (const double *)table.buf, np_ * M,
          cn, M, ix, (const double *)t.buf, n, (double *)out.buf, so, (double *)work.buf);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    PyBuffer_Release(&ctrl);
    PyBuffer_Release(&arcp);
    PyBuffer_Release(&table);
    PyBuffer_Release(&counts);
    PyBuffer_Release(&idx);
    PyBuffer_Release(&t);
    PyBuffer_Release(&out);
    PyBuffer_Release(&work);
    PyBuffer_Release(&taylor);
    PyBuffer_Release(&limits);
    return result;
}

static PyMethodDef methods[] = {
    {"rotations_block", rotations_block, METH_VARARGS, rotations_block_doc},
    {NULL, NULL, 0, NULL}};

SN_MODULE(_cspline, "C kernel of evaluate()'s staggered spline samples (see _cspline.c).", methods)
