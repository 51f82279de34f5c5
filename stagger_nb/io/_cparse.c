/* The BVH motion block's numbers, parsed in C: an optional accelerator for stagger_nb.io.bvh.

   parse_rows(buf, start, stop, rows, out, base, stride) -> int

   Parses exactly ``rows`` lines of ``buf[start:stop]``, each holding ``len(base)`` numbers, and writes the
   value of line r, column c to ``out[base[c] + r * stride[c]]`` (``out`` a writable float64 buffer,
   ``base``/``stride`` int64 buffers: any layout, e.g. channel-major or straight into an angle table).
   Returns the offset just after the last line parsed (after its '\n', or ``stop`` when that line ends
   there), or -1 -- "not handled" -- on anything it does not certify: a byte other than a plain decimal
   token ([+-]digits[.digits][(e|E)[+-]digits], or .digits), space, tab, CR or LF; a token longer than
   MAX_TOKEN bytes; a line with the wrong number of tokens (a blank line included); fewer lines than
   ``rows`` before ``stop``; a value that is not finite. The caller then runs its own parser, which
   reports the problem with its file and line. ``out`` may be partly written when -1 is returned.

   Numbers are rounded correctly, bit-identical to Python's float(token): Clinger's fast path (an integer
   mantissa <= 2^53 and a decimal exponent of at most 22 in magnitude: one exact IEEE multiplication or
   division by an exact power of ten) and, for every other token, PyOS_string_to_double (CPython's own
   correctly rounded, locale-independent strtod) with the GIL held. The GIL is released otherwise.
   Nothing is read outside [start, stop) nor written outside ``out``.

   Also quats_from_tangents (the euler -> quaternion conversion after numpy's tan) and make_continuous
   (hemisphere continuity), both bit for bit the numpy code they replace; see each function. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "../_carray.h" /* get_array: buffers checked for dtype, contiguity and writability */

/* Eight digits at a time (SWAR) read bytes as a little-endian word; the SSE2 path needs x86. Either can be
   turned off (-DCPARSE_SCALAR) to test the portable scalar path, which every other machine uses. */
#if !defined(CPARSE_SCALAR) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define CPARSE_SWAR 1
#else
#define CPARSE_SWAR 0
#endif
#if CPARSE_SWAR && defined(__SSE2__)
#define CPARSE_SSE2 1
#else
#define CPARSE_SSE2 0
#endif

#define MAX_TOKEN 64                     /* bytes of one number: real files have <= 25 */
#define MAX_MANTISSA ((uint64_t)1 << 53) /* Clinger's fast path: the mantissa is an exact double */

static const double POW10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static inline int is_blank(unsigned char ch) { return ch == ' ' || ch == '\t' || ch == '\r'; }
static inline int is_digit(unsigned char ch) { return (unsigned char)(ch - '0') < 10; }

/* The token at p (p < end, *p not blank): its value in *value and the position after it, or NULL when it
   is not a plain decimal number followed by a blank, '\n' or ``end``. ``*slow`` is set when the value
   must come from PyOS_string_to_double (then *value is not set). */
/* How many of the 8 bytes of w (little-endian: byte 0 first) are ASCII digits before the first other
   byte (8 when all are), with each digit byte's value in the matching byte of *digits. Branch-free
   (SWAR): no carry crosses a byte. */
static inline int digit_run8(uint64_t w, uint64_t *digits)
{
    const uint64_t x = w ^ 0x3030303030303030ULL; /* digits -> 0..9; every other byte -> >= 10 */
    const uint64_t big = (((x & 0x7F7F7F7F7F7F7F7FULL) + 0x7676767676767676ULL) | x) & 0x8080808080808080ULL;
    *digits = x;
    return big ? __builtin_ctzll(big) >> 3 : 8;
}

/* The number written by the first n (1..8) digit bytes of x (as from digit_run8), most significant first. */
static inline uint64_t digits_value8(uint64_t x, int n)
{
    uint64_t v = x << (8 * (8 - n)); /* the n digits become the low-order digits of an 8-digit number */
    v = v * 10 + (v >> 8);            /* pairs of digits (simdjson's parse_eight_digits_unrolled) */
    v = (((v & 0x000000FF000000FFULL) * (100 + (1000000ULL << 32))) +
         (((v >> 16) & 0x000000FF000000FFULL) * (1 + (10000ULL << 32)))) >> 32;
    return v & 0xFFFFFFFFULL;
}

static const uint64_t UPOW10[9] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000};

/* A run of digits at p appended to m (m * 10^k + the run's value, wrapping harmlessly when the caller's
   digit count exceeds 19); the position after the run. Eight bytes at a time where they lie before end. */
static inline const char *digit_run(const char *p, const char *end, uint64_t *m)
{
#if CPARSE_SWAR
    while (end - p >= 8) {
        uint64_t w, x;
        memcpy(&w, p, 8);
        int n = digit_run8(w, &x);
        if (n == 0) return p;
        *m = *m * UPOW10[n] + digits_value8(x, n);
        p += n;
        if (n < 8) return p;
    }
#endif
    while (p < end && is_digit(*p)) {
        *m = *m * 10 + (unsigned)(*p - '0');
        ++p;
    }
    return p;
}

/* The token at p (p < end, *p not blank): its value in *value and the position after it, or NULL when it
   is not a plain decimal number followed by a blank, '\n' or ``end``. ``*slow`` is set when the value
   must come from PyOS_string_to_double (then *value is not set). */
static inline const char *scan_number(const char *p, const char *end, double *value, int *slow)
{
    const char *tok = p;
    int negative = 0;
    uint64_t m = 0;  /* the digits as an integer; exact while there are at most 19 of them (< 2^64) */
    long digits;     /* digits in the mantissa (leading zeros included) */
    long exp10 = 0;  /* decimal exponent: minus the digits after the point, plus the explicit exponent */
    if (*p == '+' || *p == '-') {
        negative = *p == '-';
        if (++p == end) return NULL;
    }
    const char *d0 = p;
    p = digit_run(p, end, &m);
    digits = p - d0;
    if (p < end && *p == '.') {
        const char *f0 = ++p;
        p = digit_run(p, end, &m);
        exp10 = -(long)(p - f0);
        digits += p - f0;
    }
    if (digits == 0) return NULL; /* "", "+", ".", "-." */
    if (p < end && (*p == 'e' || *p == 'E')) {
        int eneg = 0;
        long e = 0;
        if (++p == end) return NULL;
        if (*p == '+' || *p == '-') {
            eneg = *p == '-';
            if (++p == end) return NULL;
        }
        if (!is_digit(*p)) return NULL;
        for (; p < end && is_digit(*p); ++p) {
            if (e < 100000) e = e * 10 + (*p - '0'); /* saturates: such exponents take the slow path */
        }
        exp10 += eneg ? -e : e;
    }
    if (p - tok > MAX_TOKEN) return NULL;
    if (p < end && !is_blank(*p) && *p != '\n') return NULL;
    if (digits <= 19 && m <= MAX_MANTISSA && exp10 >= -22 && exp10 <= 22) {
        double v = (double)m; /* exact: m <= 2^53 */
        v = exp10 < 0 ? v / POW10[-exp10] : v * POW10[exp10];
        *value = negative ? -v : v;
        *slow = 0;
    } else {
        *slow = 1;
    }
    return p;
}

#if CPARSE_SSE2
#include <emmintrin.h>
#define QUICK_SPAN 32 /* bytes quick_number may look at: 16 in one load, digits read 8 at a time after them */

/* The usual token -- [+-]digits[.digits] with at most 8 digits on each side, followed within 16 bytes by a
   blank or '\n' -- in one step, p + QUICK_SPAN <= end: 1 with its length in *len and its value in *value,
   0 for any other token (the caller then scans it with scan_number). The token's end is found from one
   16-byte load, so parsing it does not delay finding the next one (scan_number walks the digits first). */
static inline int quick_number(const char *p, int *len, double *value)
{
    const __m128i v = _mm_loadu_si128((const __m128i *)p);
    /* the token ends at the first byte <= ' ' (unsigned), which must be a blank or '\n' */
    const unsigned smask = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_min_epu8(v, _mm_set1_epi8(' ')), v));
    if (smask == 0) return 0;
    const int L = __builtin_ctz(smask);
    if (!is_blank(p[L]) && p[L] != '\n') return 0; /* a control byte: scan_number refuses it */
    const unsigned low = (1u << L) - 1; /* the token's bytes */
    const __m128i d = _mm_sub_epi8(v, _mm_set1_epi8('0')); /* a digit iff 0 <= d <= 9 unsigned */
    const unsigned digit = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_min_epu8(d, _mm_set1_epi8(9)), d)) & low;
    const unsigned dot = (unsigned)_mm_movemask_epi8(_mm_cmpeq_epi8(v, _mm_set1_epi8('.'))) & low;
    const unsigned negative = p[0] == '-', sign = negative | (p[0] == '+');
    if ((digit | dot | sign) != low || (dot & (dot - 1))) return 0; /* another byte, or two dots */
    const int at = dot ? __builtin_ctz(dot) : L;  /* the point, or the end */
    const int n1 = at - (int)sign, n2 = dot ? L - at - 1 : 0;
    if (n1 + n2 == 0 || n1 > 8 || n2 > 8) return 0;
    uint64_t m = 0, w;
    if (n1) {
        memcpy(&w, p + sign, 8);
        m = digits_value8(w ^ 0x3030303030303030ULL, n1);
    }
    if (n2) {
        memcpy(&w, p + at + 1, 8); /* at + 9 <= 24 < QUICK_SPAN */
        m = m * UPOW10[n2] + digits_value8(w ^ 0x3030303030303030ULL, n2);
    }
    if (m > MAX_MANTISSA) return 0; /* 16 digits may pass 2^53 */
    double x = (double)m;
    x = n2 ? x / POW10[n2] : x; /* Clinger's fast path: exact operands, one correctly rounded division */
    *value = negative ? -x : x;  /* IEEE rounding is symmetric */
    *len = L;
    return 1;
}
#endif

/* PyOS_string_to_double on the token [tok, tok + len) (len <= MAX_TOKEN), the GIL reacquired; 0 and
   *value set on success, -1 when the value is not finite or the call fails. */
static int slow_number(const char *tok, Py_ssize_t len, double *value)
{
    char text[MAX_TOKEN + 1];
    char *endp = NULL;
    double v;
    int ok;
    memcpy(text, tok, (size_t)len);
    text[len] = '\0';
    PyGILState_STATE st = PyGILState_Ensure();
    v = PyOS_string_to_double(text, &endp, NULL); /* NULL: overflow gives +-HUGE_VAL, no exception */
    ok = !PyErr_Occurred() && endp == text + len;
    if (PyErr_Occurred()) PyErr_Clear();
    PyGILState_Release(st);
    if (!ok || !isfinite(v)) return -1;
    *value = v;
    return 0;
}

static Py_ssize_t parse_block(const char *buf, Py_ssize_t start, Py_ssize_t stop, Py_ssize_t rows,
                              Py_ssize_t cols, double *out, const int64_t *base, const int64_t *stride)
{
    const char *p = buf + start, *end = buf + stop;
    Py_ssize_t r = 0, c = 0;
    while (r < rows) {
        while (p < end && is_blank(*p)) ++p;
        if (p == end || *p == '\n') { /* the end of a line (or of the block) */
            if (c != cols) return -1; /* a blank line, a short line, or too few lines */
            c = 0;
            ++r;
            if (p == end) return r == rows ? stop : -1;
            ++p;
            continue;
        }
        if (c == cols) return -1; /* a long line */
        double v;
        const char *after;
#if CPARSE_SSE2
        int len;
        if (end - p >= QUICK_SPAN && quick_number(p, &len, &v)) {
            after = p + len;
        } else
#endif
        {
            int slow;
            after = scan_number(p, end, &v, &slow);
            if (after == NULL) return -1;
            if (slow && slow_number(p, after - p, &v) < 0) return -1;
        }
        out[base[c] + (int64_t)r * stride[c]] = v;
        ++c;
        p = after;
    }
    return p - buf;
}

PyDoc_STRVAR(parse_rows_doc,
     "parse_rows(buf, start, stop, rows, out, base, stride) -> int\n\n"
     "Parse ``rows`` lines of ``buf[start:stop]`` (``len(base)`` plain decimal numbers each) into\n"
     "``out[base[c] + r * stride[c]]``; the offset after the last line, or -1 when not handled.");

static PyObject *parse_rows(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_buffer buf, out = {0}, base = {0}, stride = {0};
    PyObject *oo, *ob, *os_;
    Py_ssize_t start, stop, rows, res = -1;
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "y*nnnOOO", &buf, &start, &stop, &rows, &oo, &ob, &os_)) return NULL;
    if (get_array(oo, &out, 1, 'f', "parse_rows: out") < 0 || get_array(ob, &base, 0, 'i', "parse_rows: base") < 0 ||
        get_array(os_, &stride, 0, 'i', "parse_rows: stride") < 0)
        goto done;
    Py_ssize_t cols = base.len / (Py_ssize_t)sizeof(int64_t);
    Py_ssize_t n_out = out.len / (Py_ssize_t)sizeof(double);
    if (start < 0 || stop < start || stop > buf.len) {
        PyErr_SetString(PyExc_ValueError, "parse_rows: start and stop must satisfy 0 <= start <= stop <= len(buf)");
        goto done;
    }
    if (rows < 1 || cols < 1 || base.len != stride.len || base.len % (Py_ssize_t)sizeof(int64_t)) {
        PyErr_SetString(PyExc_ValueError,
                        "parse_rows: rows >= 1, and base and stride must be int64 buffers of one length >= 1");
        goto done;
    }
    const int64_t *b = (const int64_t *)base.buf, *s = (const int64_t *)stride.buf;
    for (Py_ssize_t c = 0; c < cols; ++c) { /* every index base[c] + r * stride[c], r < rows, lies in out */
        if (b[c] < 0 || s[c] < 0 || b[c] >= n_out || s[c] > n_out ||
            (rows > 1 && (n_out - 1 - b[c]) / (rows - 1) < s[c])) {
            PyErr_Format(PyExc_ValueError, "parse_rows: column %zd (base %lld, stride %lld) leaves out, which holds "
                         "%zd float64 values", c, (long long)b[c], (long long)s[c], n_out);
            goto done;
        }
    }
    Py_BEGIN_ALLOW_THREADS
    res = parse_block((const char *)buf.buf, start, stop, rows, cols, (double *)out.buf, b, s);
    Py_END_ALLOW_THREADS
    result = PyLong_FromSsize_t(res);
done:
    PyBuffer_Release(&buf);
    PyBuffer_Release(&out);
    PyBuffer_Release(&base);
    PyBuffer_Release(&stride);
    return result;
}

/* Hemisphere continuity in place, as stagger_nb.core.rotations.quat_continuous: q is F frames of J
   quaternions (x, y, z, w); frame f's quaternion of joint j is negated when the number of frames g <= f
   whose ORIGINAL quaternion has a negative dot product with frame g - 1's original one is odd. The dot is
   summed in the order ``(x x' + z z') + (y y' + w w')`` -- numpy's einsum on this machine (AVX-512
   build, checked by the caller before use) -- so the decisions, hence the bits, are quat_continuous's. */
static void continuity(double *q, Py_ssize_t frames, Py_ssize_t joints, double *prev, unsigned char *parity)
{
    if (frames < 1) return;
    for (Py_ssize_t j = 0; j < joints * 4; ++j) prev[j] = q[j];
    memset(parity, 0, (size_t)joints);
    for (Py_ssize_t f = 1; f < frames; ++f) {
        double *row = q + f * joints * 4;
        for (Py_ssize_t j = 0; j < joints; ++j) {
            double *a = row + 4 * j, *b = prev + 4 * j;
            double p0 = a[0] * b[0], p1 = a[1] * b[1], p2 = a[2] * b[2], p3 = a[3] * b[3];
            double dot = (p0 + p2) + (p1 + p3);
            b[0] = a[0]; b[1] = a[1]; b[2] = a[2]; b[3] = a[3];
            parity[j] ^= (unsigned char)(dot < 0.0);
            if (parity[j]) { a[0] = -a[0]; a[1] = -a[1]; a[2] = -a[2]; a[3] = -a[3]; }
        }
    }
}

PyDoc_STRVAR(make_continuous_doc,
     "make_continuous(q, joints) -> None\n\n"
     "Hemisphere continuity over time in place: ``q`` a C-contiguous float64 (F, joints, 4) buffer\n"
     "(x, y, z, w), as stagger_nb.core.rotations.quat_continuous (see _cparse.c for the sum order).");

static PyObject *make_continuous(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_buffer q;
    PyObject *oq;
    Py_ssize_t joints;
    if (!PyArg_ParseTuple(args, "On", &oq, &joints) || get_array(oq, &q, 1, 'f', "make_continuous: q") < 0)
        return NULL;
    Py_ssize_t n = q.len / (Py_ssize_t)sizeof(double);
    /* joints <= n / 4 before 4 * joints is formed: it cannot overflow (2**62 joints once wrapped it to 0) */
    if (joints < 1 || q.len % (Py_ssize_t)sizeof(double) || (n && (joints > n / 4 || n % (4 * joints)))) {
        PyErr_SetString(PyExc_ValueError, "make_continuous: q must be a float64 buffer of frames x joints x 4 values");
        PyBuffer_Release(&q);
        return NULL;
    }
    if (n == 0) {
        PyBuffer_Release(&q);
        Py_RETURN_NONE;
    }
    double *prev = PyMem_Malloc((size_t)joints * 4 * sizeof(double));
    unsigned char *parity = PyMem_Malloc((size_t)joints);
    if (prev == NULL || parity == NULL) {
        PyMem_Free(prev);
        PyMem_Free(parity);
        PyBuffer_Release(&q);
        return PyErr_NoMemory();
    }
    Py_BEGIN_ALLOW_THREADS
    continuity((double *)q.buf, n / (4 * joints), joints, prev, parity);
    Py_END_ALLOW_THREADS
    PyMem_Free(prev);
    PyMem_Free(parity);
    PyBuffer_Release(&q);
    Py_RETURN_NONE;
}

/* The rest of stagger_nb.io._common.euler_components after numpy's tan (kept there: numpy's vectorised tan
   is not libm's, and the bits must be numpy's): t holds 3 rows of n values t = tan(a/4) (row m: the angle
   about axis m of the channel order), out receives n rows (x, y, z, w). The same IEEE operations in the same
   order as the numpy code (-ffp-contract=off: no fused multiply-adds), so the same bits:
   den = t t + 1, s = (t / den) 2, c = 2 / den - 1, then the four products and the closed form below. */
static void quats_from_tan(const double *t, Py_ssize_t n, int i, int j, int k, int eps, double *out)
{
    const double *t1 = t, *t2 = t + n, *t3 = t + 2 * n;
    for (Py_ssize_t r = 0; r < n; ++r) {
        double d1 = t1[r] * t1[r] + 1.0, d2 = t2[r] * t2[r] + 1.0, d3 = t3[r] * t3[r] + 1.0;
        double s1 = (t1[r] / d1) * 2.0, s2 = (t2[r] / d2) * 2.0, s3 = (t3[r] / d3) * 2.0;
        double c1 = 2.0 / d1 - 1.0, c2 = 2.0 / d2 - 1.0, c3 = 2.0 / d3 - 1.0;
        double c1c2 = c1 * c2, s1s2 = s1 * s2, s1c2 = s1 * c2, c1s2 = c1 * s2;
        double *q = out + 4 * r;
        if (eps > 0) {
            q[i] = s1c2 * c3 + c1s2 * s3;
            q[j] = c1s2 * c3 - s1c2 * s3;
            q[k] = c1c2 * s3 + s1s2 * c3;
            q[3] = c1c2 * c3 - s1s2 * s3;
        } else {
            q[i] = s1c2 * c3 - c1s2 * s3;
            q[j] = c1s2 * c3 + s1c2 * s3;
            q[k] = c1c2 * s3 - s1s2 * c3;
            q[3] = c1c2 * c3 + s1s2 * s3;
        }
    }
}

PyDoc_STRVAR(quats_from_tangents_doc,
     "quats_from_tangents(t, axes, out) -> None\n\n"
     "``t`` (3, n) float64 tangents of a quarter of each angle (numpy's tan), ``axes`` e.g. 'ZXY':\n"
     "``out`` (n, 4) quaternions (x, y, z, w), bit for bit euler_components' (see _cparse.c).");

static PyObject *quats_from_tangents(PyObject *Py_UNUSED(self), PyObject *args)
{
    Py_buffer t, out;
    PyObject *ot, *oo;
    const char *axes;
    Py_ssize_t axes_len;
    int idx[3];
    if (!PyArg_ParseTuple(args, "Os#O", &ot, &axes, &axes_len, &oo) ||
        get_array(ot, &t, 0, 'f', "quats_from_tangents: t") < 0)
        return NULL;
    if (get_array(oo, &out, 1, 'f', "quats_from_tangents: out") < 0) {
        PyBuffer_Release(&t);
        return NULL;
    }
    Py_ssize_t n = out.len / (Py_ssize_t)(4 * sizeof(double));
    int ok = axes_len == 3 && out.len % (Py_ssize_t)(4 * sizeof(double)) == 0 &&
             t.len == 3 * n * (Py_ssize_t)sizeof(double);
    for (int m = 0; ok && m < 3; ++m) {
        const char *at = strchr("XYZ", axes[m]);
        ok = axes[m] != '\0' && at != NULL;
        if (ok) idx[m] = (int)(at - "XYZ");
    }
    if (ok) ok = idx[0] != idx[1] && idx[1] != idx[2] && idx[0] != idx[2];
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "quats_from_tangents: t must hold 3 x n float64 values, out 4 x n, "
                                          "axes three distinct letters of 'XYZ'");
        PyBuffer_Release(&t);
        PyBuffer_Release(&out);
        return NULL;
    }
    int eps = ((idx[1] - idx[0] + 3) % 3 == 1) ? 1 : -1; /* +1 when e_i x e_j = e_k */
    Py_BEGIN_ALLOW_THREADS
    quats_from_tan((const double *)t.buf, n, idx[0], idx[1], idx[2], eps, (double *)out.buf);
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&t);
    PyBuffer_Release(&out);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"quats_from_tangents", quats_from_tangents, METH_VARARGS, quats_from_tangents_doc},
    {"make_continuous", make_continuous, METH_VARARGS, make_continuous_doc},
    {"parse_rows", parse_rows, METH_VARARGS, parse_rows_doc},
    {NULL, NULL, 0, NULL}};

SN_MODULE(_cparse, "C parser of the BVH motion block (see _cparse.c).", methods)
