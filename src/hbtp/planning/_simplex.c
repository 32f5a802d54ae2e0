/* A small dual simplex for the state equation's linear program (hbtp.planning.flow), in C.
 *
 * The program: minimise cost . Y over Y >= 0 with lower <= A Y <= upper, where only the row bounds
 * change from one condition to the next. Each row r gets a slack s_r = (A Y)_r with bounds
 * [lower_r, upper_r], so that a basis of the columns [A, -I] is kept between solves: the reduced
 * costs depend on the basis alone, so the last optimal basis stays dual feasible for new bounds, and
 * the dual simplex only repairs the basic values that the new bounds leave out of range (a few pivots
 * where HiGHS pays a fixed cost of about 100 us a solve). The basis inverse is kept dense (the
 * programs have a few hundred rows at most: hbtp.planning.flow asks HiGHS beyond that), updated
 * at each pivot and recomputed from the basis every REFACTOR pivots.
 *
 * Program(cols, rows, start, index, value, cost): the columns in compressed form (int32 start[cols
 *     + 1], int32 index[nnz], double value[nnz]) and the costs (double[cols], all >= 0).
 * solve(lower, upper) -> (status, value): doubles[rows] (+-inf: no bound); status 0 optimal (value
 *     the least cost), 1 infeasible (value inf), 2 gave up (value 0: the caller asks another solver).
 * ray() -> bytes: after status 1, double[rows]: the row multipliers of the proof (nonzero: the row's
 *     bounds take part), as HiGHS's dual ray names them.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define REFACTOR 64
#define PRIMAL_TOL 1e-9
#define DUAL_TOL 1e-9
#define PIVOT_TOL 1e-9

enum { BASIC = 0, AT_LOWER = 1, AT_UPPER = 2 };

typedef struct {
    PyObject_HEAD
    Py_ssize_t m, n;  // rows, columns
    int32_t *start, *index;
    double *value, *cost;
    double *lower, *upper;  // per variable (n structural then m slacks)
    double *x, *d;           // values, reduced costs, per variable
    int32_t *head;           // the variable basic in each row position
    unsigned char *state;    // per variable: BASIC, AT_LOWER, AT_UPPER
    double *inverse;         // m * m, row-major
    double *work, *alpha, *column, *ray, *scratch;
    int32_t *nonzero;        // 2 * m, scratch: the nonzero positions of pivot rows
    double *weight;          // per row position, the squared norm of its row of the inverse
    int pivots;              // since the inverse was last computed
    long long pivots_made;   // in every solve so far
    int ray_ready;
} Program;

static double var_cost(Program *p, Py_ssize_t j) { return j < p->n ? p->cost[j] : 0.0; }

/* alpha[j] = row . a'_j for the nonbasic variables j (a'_j: column j of [A, -I]). */
static void pivot_row(Program *p, const double *row) {
    for (Py_ssize_t j = 0; j < p->n; j++) {
        if (p->state[j] == BASIC) continue;
        double sum = 0.0;
        for (int32_t k = p->start[j]; k < p->start[j + 1]; k++) sum += row[p->index[k]] * p->value[k];
        p->alpha[j] = sum;
    }
    for (Py_ssize_t i = 0; i < p->m; i++)
        if (p->state[p->n + i] != BASIC) p->alpha[p->n + i] = -row[i];
}

/* column = inverse . a'_q */
static void pivot_column(Program *p, Py_ssize_t q) {
    Py_ssize_t m = p->m;
    if (q >= p->n) {
        Py_ssize_t i = q - p->n;
        for (Py_ssize_t r = 0; r < m; r++) p->column[r] = -p->inverse[r * m + i];
        return;
    }
    memset(p->column, 0, (size_t)m * sizeof(double));
    for (int32_t k = p->start[q]; k < p->start[q + 1]; k++) {
        Py_ssize_t i = p->index[k];
        double v = p->value[k];
        for (Py_ssize_t r = 0; r < m; r++) p->column[r] += p->inverse[r * m + i] * v;
    }
}

/* The basic values from the nonbasic ones: B x_B = -N x_N (only slacks away from 0 contribute:
 * structural columns are nonbasic at 0). */
static void basic_values(Program *p) {
    Py_ssize_t m = p->m;
    for (Py_ssize_t r = 0; r < m; r++) p->x[p->head[r]] = 0.0;
    for (Py_ssize_t i = 0; i < m; i++) {
        Py_ssize_t j = p->n + i;
        double v = p->x[j];
        if (p->state[j] == BASIC || v == 0.0) continue;
        for (Py_ssize_t r = 0; r < m; r++) p->x[p->head[r]] += p->inverse[r * m + i] * v;
    }
}

/* The reduced costs: d = c - a'^T y with y = c_B^T inverse. */
static void reduced_costs(Program *p) {
    Py_ssize_t m = p->m;
    double *y = p->work;
    memset(y, 0, (size_t)m * sizeof(double));
    for (Py_ssize_t r = 0; r < m; r++) {
        double c = var_cost(p, p->head[r]);
        if (c == 0.0) continue;
        for (Py_ssize_t i = 0; i < m; i++) y[i] += c * p->inverse[r * m + i];
    }
    for (Py_ssize_t j = 0; j < p->n; j++) {
        double sum = 0.0;
        for (int32_t k = p->start[j]; k < p->start[j + 1]; k++) sum += y[p->index[k]] * p->value[k];
        p->d[j] = p->state[j] == BASIC ? 0.0 : p->cost[j] - sum;
    }
    for (Py_ssize_t i = 0; i < m; i++) p->d[p->n + i] = p->state[p->n + i] == BASIC ? 0.0 : y[i];
}

/* The slack basis: B = -I, every structural column at 0 (dual feasible: the costs are >= 0). */
static void slack_basis(Program *p) {
    Py_ssize_t m = p->m, n = p->n;
    memset(p->inverse, 0, (size_t)(m * m) * sizeof(double));
    for (Py_ssize_t j = 0; j < n; j++) {
        p->state[j] = AT_LOWER;
        p->x[j] = 0.0;
        p->d[j] = p->cost[j];
    }
    for (Py_ssize_t i = 0; i < m; i++) {
        p->head[i] = (int32_t)(n + i);
        p->state[n + i] = BASIC;
        p->d[n + i] = 0.0;
        p->inverse[i * m + i] = -1.0;
        p->weight[i] = 1.0;
    }
    p->pivots = 0;
}

/* The inverse recomputed from the basis by Gauss-Jordan elimination with partial pivoting; 0 if the
 * basis is singular. */
static int refactor(Program *p) {
    Py_ssize_t m = p->m;
    double *b = p->scratch;  // m * m, the basis then eliminated
    memset(b, 0, (size_t)(m * m) * sizeof(double));
    for (Py_ssize_t r = 0; r < m; r++) {
        Py_ssize_t j = p->head[r];
        if (j >= p->n)
            b[(j - p->n) * m + r] = -1.0;
        else
            for (int32_t k = p->start[j]; k < p->start[j + 1]; k++) b[p->index[k] * m + r] = p->value[k];
    }
    double *inv = p->inverse;
    memset(inv, 0, (size_t)(m * m) * sizeof(double));
    for (Py_ssize_t i = 0; i < m; i++) inv[i * m + i] = 1.0;
    for (Py_ssize_t c = 0; c < m; c++) {
        Py_ssize_t best = c;
        for (Py_ssize_t r = c + 1; r < m; r++)
            if (fabs(b[r * m + c]) > fabs(b[best * m + c])) best = r;
        if (fabs(b[best * m + c]) < 1e-12) return 0;
        if (best != c) {
            for (Py_ssize_t k = 0; k < m; k++) {
                double t = b[c * m + k];
                b[c * m + k] = b[best * m + k];
                b[best * m + k] = t;
                t = inv[c * m + k];
                inv[c * m + k] = inv[best * m + k];
                inv[best * m + k] = t;
            }
        }
        double pivot = b[c * m + c];
        // Only the nonzero entries of the pivot rows take part (the bases are sparse).
        int32_t *in_b = p->nonzero, *in_inv = p->nonzero + m, nb = 0, ni = 0;
        for (Py_ssize_t k = 0; k < m; k++) {
            if (b[c * m + k] != 0.0) {
                b[c * m + k] /= pivot;
                in_b[nb++] = (int32_t)k;
            }
            if (inv[c * m + k] != 0.0) {
                inv[c * m + k] /= pivot;
                in_inv[ni++] = (int32_t)k;
            }
        }
        for (Py_ssize_t r = 0; r < m; r++) {
            double f = b[r * m + c];
            if (r == c || f == 0.0) continue;
            for (int32_t t = 0; t < nb; t++) b[r * m + in_b[t]] -= f * b[c * m + in_b[t]];
            for (int32_t t = 0; t < ni; t++) inv[r * m + in_inv[t]] -= f * inv[c * m + in_inv[t]];
        }
    }
    for (Py_ssize_t r = 0; r < m; r++) {
        double norm = 0.0;
        for (Py_ssize_t k = 0; k < m; k++) norm += inv[r * m + k] * inv[r * m + k];
        p->weight[r] = norm;
    }
    p->pivots = 0;
    return 1;
}

/* Place each nonbasic variable at the bound its reduced cost asks for; 0 if one cannot be (its
 * bound is infinite: the basis is not dual feasible for these bounds). */
static int place_nonbasic(Program *p) {
    Py_ssize_t total = p->n + p->m;
    for (Py_ssize_t j = 0; j < total; j++) {
        if (p->state[j] == BASIC) continue;
        double lo = p->lower[j], up = p->upper[j], dj = p->d[j];
        // A reduced cost of about 0 allows either bound: the one the variable is at is kept, so that
        // bounds asked again need no pivot.
        int keep_upper = p->state[j] == AT_UPPER && up != INFINITY && dj <= DUAL_TOL;
        if (lo == up) {
            p->state[j] = AT_LOWER;
            p->x[j] = lo;
        } else if (!keep_upper && (dj > DUAL_TOL || (dj >= -DUAL_TOL && lo != -INFINITY))) {
            if (lo == -INFINITY) return 0;
            p->state[j] = AT_LOWER;
            p->x[j] = lo;
        } else {
            if (up == INFINITY) return 0;
            p->state[j] = AT_UPPER;
            p->x[j] = up;
        }
    }
    return 1;
}

static void pivot(Program *p, Py_ssize_t r, Py_ssize_t q, int to_upper) {
    Py_ssize_t m = p->m;
    Py_ssize_t leaving = p->head[r];
    double *col = p->column, a_rq = col[r];
    double bound = to_upper ? p->upper[leaving] : p->lower[leaving];
    double step = (p->x[leaving] - bound) / a_rq;
    for (Py_ssize_t i = 0; i < m; i++)
        if (i != r) p->x[p->head[i]] -= step * col[i];
    p->x[q] += step;
    p->x[leaving] = bound;
    double theta = p->d[q] / a_rq;
    Py_ssize_t total = p->n + m;
    for (Py_ssize_t j = 0; j < total; j++)
        if (p->state[j] != BASIC) p->d[j] -= theta * p->alpha[j];
    p->d[q] = 0.0;
    p->d[leaving] = -theta;
    double *inv = p->inverse, *row = inv + r * m;
    int32_t *nonzero = p->nonzero, count = 0;
    for (Py_ssize_t k = 0; k < m; k++) {
        if (row[k] == 0.0) continue;
        row[k] /= a_rq;
        nonzero[count++] = (int32_t)k;
    }
    // The rows' squared norms follow the update: |row_i - f row_r|² = w_i - 2 f (row_i . row_r) + f² w_r.
    double w_r = p->weight[r] / (a_rq * a_rq);
    for (Py_ssize_t i = 0; i < m; i++) {
        double f = col[i];
        if (i == r || f == 0.0) continue;
        double *target = inv + i * m, dot = 0.0;
        for (int32_t t = 0; t < count; t++) {
            int32_t k = nonzero[t];
            dot += target[k] * row[k];
            target[k] -= f * row[k];
        }
        double w = p->weight[i] - 2.0 * f * dot + f * f * w_r;
        p->weight[i] = w > 1e-12 ? w : 1e-12;
    }
    p->weight[r] = w_r;
    p->head[r] = (int32_t)q;
    p->state[q] = BASIC;
    p->state[leaving] = to_upper ? AT_UPPER : AT_LOWER;
    p->pivots++;
    p->pivots_made++;
}

/* The dual simplex from the current basis: 0 optimal, 1 infeasible, 2 gave up. */
static int dual_simplex(Program *p) {
    Py_ssize_t m = p->m, total = p->n + m;
    long limit = 500 + 2 * (long)m;  // a solve from a warm basis takes a few pivots; past this, give up
    for (long iteration = 0; iteration < limit; iteration++) {
        if (p->pivots >= REFACTOR) {
            if (!refactor(p)) return 2;
            basic_values(p);
            reduced_costs(p);
        }
        // The leaving row: the largest infeasibility relative to the norm of its row of the inverse
        // (dual steepest edge; the norms are updated at each pivot, recomputed with the inverse).
        Py_ssize_t r = -1;
        double best_score = 0.0;
        int to_upper = 0;
        for (Py_ssize_t i = 0; i < m; i++) {
            Py_ssize_t j = p->head[i];
            double v = p->x[j], gap;
            int up;
            if (p->lower[j] - v > PRIMAL_TOL) {
                gap = p->lower[j] - v;
                up = 0;
            } else if (v - p->upper[j] > PRIMAL_TOL) {
                gap = v - p->upper[j];
                up = 1;
            } else {
                continue;
            }
            double score = gap * gap / p->weight[i];
            if (score > best_score) {
                best_score = score;
                r = i;
                to_upper = up;
            }
        }
        if (r < 0) return 0;
        const double *row = p->inverse + r * m;
        pivot_row(p, row);
        Py_ssize_t q = -1;
        double best = INFINITY, best_size = 0.0;
        for (Py_ssize_t j = 0; j < total; j++) {
            unsigned char s = p->state[j];
            if (s == BASIC || p->lower[j] == p->upper[j]) continue;
            double a = p->alpha[j];
            // Leaving to its lower bound, x_p must rise: j at lower with a < 0, or at upper with a > 0.
            int eligible = to_upper ? ((s == AT_LOWER && a > PIVOT_TOL) || (s == AT_UPPER && a < -PIVOT_TOL))
                                    : ((s == AT_LOWER && a < -PIVOT_TOL) || (s == AT_UPPER && a > PIVOT_TOL));
            if (!eligible) continue;
            double ratio = fabs(p->d[j]) / fabs(a);
            if (ratio < best - 1e-12 || (ratio <= best + 1e-12 && fabs(a) > best_size)) {
                best = ratio;
                best_size = fabs(a);
                q = j;
            }
        }
        if (q < 0) {
            memcpy(p->ray, row, (size_t)m * sizeof(double));
            p->ray_ready = 1;
            return 1;
        }
        pivot_column(p, q);
        if (fabs(p->column[r]) < PIVOT_TOL) return 2;
        pivot(p, r, q, to_upper);
    }
    return 2;
}

static PyObject *program_solve(Program *p, PyObject *args) {
    Py_buffer lower, upper;
    if (!PyArg_ParseTuple(args, "y*y*", &lower, &upper)) return NULL;
    Py_ssize_t m = p->m, n = p->n;
    if (lower.len != m * (Py_ssize_t)sizeof(double) || upper.len != m * (Py_ssize_t)sizeof(double)) {
        PyBuffer_Release(&lower);
        PyBuffer_Release(&upper);
        return PyErr_Format(PyExc_ValueError, "the bounds must be %zd doubles each", m);
    }
    memcpy(p->lower + n, lower.buf, (size_t)m * sizeof(double));
    memcpy(p->upper + n, upper.buf, (size_t)m * sizeof(double));
    PyBuffer_Release(&lower);
    PyBuffer_Release(&upper);
    p->ray_ready = 0;
    for (Py_ssize_t i = 0; i < m; i++) {
        if (p->lower[n + i] > p->upper[n + i]) {  // a row whose bounds cross: its own proof
            memset(p->ray, 0, (size_t)m * sizeof(double));
            p->ray[i] = 1.0;
            p->ray_ready = 1;
            return Py_BuildValue("(id)", 1, INFINITY);
        }
    }
    if (!place_nonbasic(p)) {
        slack_basis(p);
        place_nonbasic(p);  // always succeeds from the slack basis: structural columns sit at 0
    }
    basic_values(p);
    int status = dual_simplex(p);
    if (status == 2) {  // numerical trouble: start again from the slack basis once
        slack_basis(p);
        place_nonbasic(p);
        basic_values(p);
        status = dual_simplex(p);
        if (status == 2) slack_basis(p);
    }
    double value = 0.0;
    if (status == 1)
        value = INFINITY;
    else if (status == 0)
        for (Py_ssize_t r = 0; r < m; r++) {
            Py_ssize_t j = p->head[r];
            if (j < n) value += p->cost[j] * p->x[j];
        }
    return Py_BuildValue("(id)", status, value);
}

static PyObject *program_ray(Program *p, PyObject *unused) {
    if (!p->ray_ready) {
        PyErr_SetString(PyExc_RuntimeError, "no proof of infeasibility: the last solve was not infeasible");
        return NULL;
    }
    return PyBytes_FromStringAndSize((const char *)p->ray, p->m * (Py_ssize_t)sizeof(double));
}

static PyObject *program_pivots(Program *p, PyObject *unused) { return PyLong_FromLongLong(p->pivots_made); }

static void program_dealloc(Program *p) {
    free(p->start);
    free(p->index);
    free(p->value);
    free(p->cost);
    free(p->lower);
    free(p->upper);
    free(p->x);
    free(p->d);
    free(p->head);
    free(p->state);
    free(p->inverse);
    free(p->work);
    free(p->alpha);
    free(p->column);
    free(p->ray);
    free(p->scratch);
    free(p->nonzero);
    free(p->weight);
    Py_TYPE(p)->tp_free((PyObject *)p);
}

static void *copy_of(Py_buffer *b) {
    void *out = malloc(b->len ? (size_t)b->len : 1);
    if (out != NULL) memcpy(out, b->buf, (size_t)b->len);
    return out;
}

static int program_init(Program *p, PyObject *args, PyObject *kwds) {
    Py_ssize_t n, m;
    Py_buffer start, index, value, cost;
    if (!PyArg_ParseTuple(args, "nny*y*y*y*", &n, &m, &start, &index, &value, &cost)) return -1;
    int ok = 0;
    Py_ssize_t nnz = index.len / (Py_ssize_t)sizeof(int32_t);
    if (n < 0 || m < 0 || start.len != (n + 1) * (Py_ssize_t)sizeof(int32_t) ||
        value.len != nnz * (Py_ssize_t)sizeof(double) || cost.len != n * (Py_ssize_t)sizeof(double)) {
        PyErr_SetString(PyExc_ValueError, "the program's arrays do not match");
        goto done;
    }
    const int32_t *s = start.buf, *ix = index.buf;
    const double *cs = cost.buf;
    if (s[0] != 0 || s[n] != nnz) {
        PyErr_SetString(PyExc_ValueError, "the column starts do not match");
        goto done;
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        if (s[j] > s[j + 1] || !(cs[j] >= 0.0) || cs[j] == INFINITY) {
            PyErr_SetString(PyExc_ValueError, "column starts must not decrease and costs must be finite and >= 0");
            goto done;
        }
    }
    for (Py_ssize_t k = 0; k < nnz; k++)
        if (ix[k] < 0 || ix[k] >= m) {
            PyErr_SetString(PyExc_ValueError, "a row index is out of range");
            goto done;
        }
    Py_ssize_t total = n + m;
    p->n = n;
    p->m = m;
    p->start = copy_of(&start);
    p->index = copy_of(&index);
    p->value = copy_of(&value);
    p->cost = copy_of(&cost);
    p->lower = malloc((size_t)(total + 1) * sizeof(double));
    p->upper = malloc((size_t)(total + 1) * sizeof(double));
    p->x = calloc((size_t)total + 1, sizeof(double));
    p->d = calloc((size_t)total + 1, sizeof(double));
    p->head = malloc((size_t)m * sizeof(int32_t) + 1);
    p->state = malloc((size_t)total + 1);
    p->inverse = malloc((size_t)(m * m) * sizeof(double) + 1);
    p->scratch = malloc((size_t)(m * m) * sizeof(double) + 1);
    p->work = malloc((size_t)m * sizeof(double) + 1);
    p->alpha = calloc((size_t)total + 1, sizeof(double));
    p->column = malloc((size_t)m * sizeof(double) + 1);
    p->ray = malloc((size_t)m * sizeof(double) + 1);
    p->nonzero = malloc((size_t)(2 * m) * sizeof(int32_t) + 1);
    p->weight = malloc((size_t)m * sizeof(double) + 1);
    if (!p->start || !p->index || !p->value || !p->cost || !p->lower || !p->upper || !p->x || !p->d || !p->head ||
        !p->state || !p->inverse || !p->scratch || !p->work || !p->alpha || !p->column || !p->ray ||
        !p->nonzero || !p->weight) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t j = 0; j < n; j++) {
        p->lower[j] = 0.0;
        p->upper[j] = INFINITY;
    }
    for (Py_ssize_t i = 0; i < m; i++) {
        p->lower[n + i] = -INFINITY;
        p->upper[n + i] = INFINITY;
    }
    slack_basis(p);
    ok = 1;
done:
    PyBuffer_Release(&start);
    PyBuffer_Release(&index);
    PyBuffer_Release(&value);
    PyBuffer_Release(&cost);
    return ok ? 0 : -1;
}

static PyMethodDef program_methods[] = {
    {"solve", (PyCFunction)program_solve, METH_VARARGS, "solve(lower, upper) -> (status, value)"},
    {"ray", (PyCFunction)program_ray, METH_NOARGS, "The last proof of infeasibility's row multipliers."},
    {"pivots", (PyCFunction)program_pivots, METH_NOARGS, "How many pivots every solve so far made."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject ProgramType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "hbtp.planning._simplex.Program",
    .tp_basicsize = sizeof(Program),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The state equation's program, solved by a dual simplex kept warm between bounds.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)program_init,
    .tp_dealloc = (destructor)program_dealloc,
    .tp_methods = program_methods,
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_simplex", "A small warm dual simplex in C.", -1};

PyMODINIT_FUNC PyInit__simplex(void) {
    if (PyType_Ready(&ProgramType) < 0) return NULL;
    PyObject *mod = PyModule_Create(&module);
    if (mod == NULL) return NULL;
    Py_INCREF(&ProgramType);
    if (PyModule_AddObject(mod, "Program", (PyObject *)&ProgramType) < 0) {
        Py_DECREF(&ProgramType);
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
