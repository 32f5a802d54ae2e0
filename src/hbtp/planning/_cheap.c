/* The cheap estimates of a condition in C: h² (hbtp.planning.pairs.PairCosts) and the landmark sum
 * (hbtp.planning.heuristics.LandmarkSum), asked for every condition the search generates.
 *
 * The Python classes document the estimates and hold the reference implementations; these functions
 * compute the same values from flat tables that the classes make once (tests/test_cheap.py compares
 * them). Built when a C compiler is present (an optional extension: without one, hbtp runs Python).
 *
 * pair_table(n, rows) -> bytes
 *     rows: per atom p, (levels, masks): the levels at which p's pairs grew and, joined, the masks of
 *     the atoms paired with p at each (n bits little-endian, (n + 7) // 8 bytes each). Returns the
 *     n * n doubles h²({p, q}) (inf: never reached), the larger of the two orders.
 * pair_cost(table, n, condition) -> float
 *     the largest h² of a pair of the condition's atoms (an atom pairs with itself); 0 when empty.
 * bit_lists(n, masks) -> (spans, items)
 *     masks: per atom, n bits as above, or None. spans: int32 [begin, end) per atom into items
 *     (begin -1 for None); items: int32, the positions of the bits set, lowest first.
 * landmark_sum(tables, condition) -> float
 *     tables: (spans, items, share, stamps, hmax or None); share: doubles, 0 for the atoms of s0;
 *     stamps: a bytearray of n + 1 uint32 (scratch). inf when an atom has no landmarks (None); else
 *     ceil(sum of share over the union of the atoms' landmarks - 1e-9), and at least the largest hmax
 *     of the atoms when hmax is given; 0 for an empty condition.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define STACK_ATOMS 256

/* The condition's atoms as ints in [0, n): into `stack` when they fit, else a new buffer (*heap). */
static int collect(PyObject *condition, Py_ssize_t n, int32_t *stack, int32_t **atoms, int32_t **heap,
                   Py_ssize_t *count) {
    PyObject *iterator = PyObject_GetIter(condition);
    if (iterator == NULL) return -1;
    Py_ssize_t room = STACK_ATOMS, size = 0;
    int32_t *buffer = stack;
    *heap = NULL;
    PyObject *item;
    while ((item = PyIter_Next(iterator)) != NULL) {
        long atom = PyLong_AsLong(item);
        Py_DECREF(item);
        if (atom == -1 && PyErr_Occurred()) goto fail;
        if (atom < 0 || atom >= n) {
            PyErr_Format(PyExc_IndexError, "atom %ld out of range", atom);
            goto fail;
        }
        if (size == room) {
            room *= 2;
            int32_t *grown = malloc((size_t)room * sizeof(int32_t));
            if (grown == NULL) {
                PyErr_NoMemory();
                goto fail;
            }
            memcpy(grown, buffer, (size_t)size * sizeof(int32_t));
            free(*heap);
            *heap = buffer = grown;
        }
        buffer[size++] = (int32_t)atom;
    }
    Py_DECREF(iterator);
    if (PyErr_Occurred()) {
        free(*heap);
        *heap = NULL;
        return -1;
    }
    *atoms = buffer;
    *count = size;
    return 0;
fail:
    Py_DECREF(iterator);
    free(*heap);
    *heap = NULL;
    return -1;
}

static PyObject *pair_table(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    PyObject *rows;
    if (!PyArg_ParseTuple(args, "nO", &n, &rows)) return NULL;
    if (n < 0 || n > 46340) return PyErr_Format(PyExc_ValueError, "bad atom count %zd", n);
    PyObject *result = PyBytes_FromStringAndSize(NULL, n * n * (Py_ssize_t)sizeof(double));
    if (result == NULL) return NULL;
    double *table = (double *)PyBytes_AS_STRING(result);
    for (Py_ssize_t i = 0; i < n * n; i++) table[i] = INFINITY;
    Py_ssize_t size = (n + 7) / 8;
    PyObject *iterator = PyObject_GetIter(rows);
    if (iterator == NULL) goto fail;
    PyObject *row;
    Py_ssize_t p = 0;
    while ((row = PyIter_Next(iterator)) != NULL) {
        PyObject *levels, *masks;
        if (p >= n || !PyArg_ParseTuple(row, "OS", &levels, &masks)) {
            if (!PyErr_Occurred()) PyErr_SetString(PyExc_ValueError, "more rows than atoms");
            Py_DECREF(row);
            goto fail_iterating;
        }
        PyObject *fast = PySequence_Fast(levels, "levels must be a sequence");
        if (fast == NULL) {
            Py_DECREF(row);
            goto fail_iterating;
        }
        Py_ssize_t entries = PySequence_Fast_GET_SIZE(fast);
        if (PyBytes_GET_SIZE(masks) != entries * size) {
            PyErr_SetString(PyExc_ValueError, "masks do not match the levels");
            Py_DECREF(fast);
            Py_DECREF(row);
            goto fail_iterating;
        }
        const unsigned char *bits = (const unsigned char *)PyBytes_AS_STRING(masks);
        double *out = table + p * n;
        for (Py_ssize_t e = 0; e < entries; e++) {
            double level = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, e));
            if (level == -1.0 && PyErr_Occurred()) {
                Py_DECREF(fast);
                Py_DECREF(row);
                goto fail_iterating;
            }
            const unsigned char *mask = bits + e * size;
            for (Py_ssize_t byte = 0; byte < size; byte++) {
                unsigned char set = mask[byte];
                while (set) {
                    int bit = __builtin_ctz(set);
                    set &= (unsigned char)(set - 1);
                    Py_ssize_t q = byte * 8 + bit;
                    if (q < n && out[q] == INFINITY) out[q] = level;
                }
            }
        }
        Py_DECREF(fast);
        Py_DECREF(row);
        p++;
    }
    Py_DECREF(iterator);
    if (PyErr_Occurred()) goto fail;
    for (Py_ssize_t a = 0; a < n; a++) {
        for (Py_ssize_t b = a + 1; b < n; b++) {
            double larger = table[a * n + b] > table[b * n + a] ? table[a * n + b] : table[b * n + a];
            table[a * n + b] = table[b * n + a] = larger;
        }
    }
    return result;
fail_iterating:
    Py_DECREF(iterator);
fail:
    Py_DECREF(result);
    return NULL;
}

static PyObject *pair_cost(PyObject *self, PyObject *args) {
    PyObject *table_bytes, *condition;
    Py_ssize_t n;
    if (!PyArg_ParseTuple(args, "SnO", &table_bytes, &n, &condition)) return NULL;
    if (PyBytes_GET_SIZE(table_bytes) != n * n * (Py_ssize_t)sizeof(double))
        return PyErr_Format(PyExc_ValueError, "the table does not hold %zd atoms", n);
    const double *table = (const double *)PyBytes_AS_STRING(table_bytes);
    int32_t stack[STACK_ATOMS];
    int32_t *atoms, *heap;
    Py_ssize_t count;
    if (collect(condition, n, stack, &atoms, &heap, &count) < 0) return NULL;
    double best = 0.0;
    for (Py_ssize_t i = 0; i < count && best != INFINITY; i++) {
        const double *row = table + (Py_ssize_t)atoms[i] * n;
        for (Py_ssize_t j = i; j < count; j++) {
            double value = row[atoms[j]];
            if (value > best) {
                best = value;
                if (best == INFINITY) break;
            }
        }
    }
    free(heap);
    return PyFloat_FromDouble(best);
}

static PyObject *bit_lists(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    PyObject *masks;
    if (!PyArg_ParseTuple(args, "nO", &n, &masks)) return NULL;
    if (n < 0 || n > INT32_MAX / 2) return PyErr_Format(PyExc_ValueError, "bad atom count %zd", n);
    Py_ssize_t size = (n + 7) / 8, used = 0, room = 1024;
    int32_t *spans = malloc((size_t)(2 * n + 1) * sizeof(int32_t));
    int32_t *items = malloc((size_t)room * sizeof(int32_t));
    PyObject *iterator = NULL, *result = NULL;
    if (spans == NULL || items == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    iterator = PyObject_GetIter(masks);
    if (iterator == NULL) goto done;
    PyObject *mask;
    Py_ssize_t p = 0;
    while ((mask = PyIter_Next(iterator)) != NULL) {
        if (p >= n) {
            Py_DECREF(mask);
            PyErr_SetString(PyExc_ValueError, "more masks than atoms");
            goto done;
        }
        if (mask == Py_None) {
            spans[2 * p] = spans[2 * p + 1] = -1;
        } else if (!PyBytes_Check(mask) || PyBytes_GET_SIZE(mask) != size) {
            Py_DECREF(mask);
            PyErr_SetString(PyExc_ValueError, "a mask is not bytes of the atoms' size");
            goto done;
        } else {
            const unsigned char *bits = (const unsigned char *)PyBytes_AS_STRING(mask);
            spans[2 * p] = (int32_t)used;
            for (Py_ssize_t byte = 0; byte < size; byte++) {
                unsigned char set = bits[byte];
                while (set) {
                    int bit = __builtin_ctz(set);
                    set &= (unsigned char)(set - 1);
                    if (used == room) {
                        if (room > INT32_MAX / 2) {
                            Py_DECREF(mask);
                            PyErr_SetString(PyExc_OverflowError, "too many landmarks");
                            goto done;
                        }
                        room *= 2;
                        int32_t *grown = realloc(items, (size_t)room * sizeof(int32_t));
                        if (grown == NULL) {
                            Py_DECREF(mask);
                            PyErr_NoMemory();
                            goto done;
                        }
                        items = grown;
                    }
                    items[used++] = (int32_t)(byte * 8 + bit);
                }
            }
            spans[2 * p + 1] = (int32_t)used;
        }
        Py_DECREF(mask);
        p++;
    }
    if (PyErr_Occurred()) goto done;
    if (p != n) {
        PyErr_SetString(PyExc_ValueError, "fewer masks than atoms");
        goto done;
    }
    result = Py_BuildValue("(y#y#)", (const char *)spans, (Py_ssize_t)(2 * n * sizeof(int32_t)), (const char *)items,
                           (Py_ssize_t)(used * (Py_ssize_t)sizeof(int32_t)));
done:
    Py_XDECREF(iterator);
    free(spans);
    free(items);
    return result;
}

static PyObject *landmark_sum(PyObject *self, PyObject *args) {
    PyObject *tables, *condition, *spans_b, *items_b, *share_b, *stamps_b, *hmax_b;
    if (!PyArg_ParseTuple(args, "O!O", &PyTuple_Type, &tables, &condition)) return NULL;
    if (!PyArg_ParseTuple(tables, "SSSYO", &spans_b, &items_b, &share_b, &stamps_b, &hmax_b)) return NULL;
    Py_ssize_t n = PyBytes_GET_SIZE(share_b) / (Py_ssize_t)sizeof(double);
    if (PyBytes_GET_SIZE(spans_b) != 2 * n * (Py_ssize_t)sizeof(int32_t) ||
        PyByteArray_GET_SIZE(stamps_b) != (n + 1) * (Py_ssize_t)sizeof(uint32_t) ||
        (hmax_b != Py_None && (!PyBytes_Check(hmax_b) || PyBytes_GET_SIZE(hmax_b) != PyBytes_GET_SIZE(share_b)))) {
        PyErr_SetString(PyExc_ValueError, "the landmark tables do not match");
        return NULL;
    }
    const int32_t *spans = (const int32_t *)PyBytes_AS_STRING(spans_b);
    const int32_t *items = (const int32_t *)PyBytes_AS_STRING(items_b);
    Py_ssize_t item_count = PyBytes_GET_SIZE(items_b) / (Py_ssize_t)sizeof(int32_t);
    const double *share = (const double *)PyBytes_AS_STRING(share_b);
    uint32_t *stamps = (uint32_t *)PyByteArray_AS_STRING(stamps_b);
    int32_t stack[STACK_ATOMS];
    int32_t *atoms, *heap;
    Py_ssize_t count;
    if (collect(condition, n, stack, &atoms, &heap, &count) < 0) return NULL;
    double result = 0.0;
    if (count == 0) goto done;
    for (Py_ssize_t i = 0; i < count; i++) {
        if (spans[2 * atoms[i]] < 0) {
            result = INFINITY;
            goto done;
        }
    }
    uint32_t stamp = stamps[n] + 1;
    if (stamp == 0) {  // wrapped around: every old mark must go
        memset(stamps, 0, (size_t)n * sizeof(uint32_t));
        stamp = 1;
    }
    stamps[n] = stamp;
    double total = 0.0;
    for (Py_ssize_t i = 0; i < count; i++) {
        int32_t begin = spans[2 * atoms[i]], end = spans[2 * atoms[i] + 1];
        if (end > item_count) {
            PyErr_SetString(PyExc_ValueError, "the landmark tables do not match");
            free(heap);
            return NULL;
        }
        for (int32_t k = begin; k < end; k++) {
            int32_t f = items[k];
            if (stamps[f] != stamp) {
                stamps[f] = stamp;
                total += share[f];
            }
        }
    }
    result = ceil(total - 1e-9);
    if (hmax_b != Py_None) {
        const double *hmax = (const double *)PyBytes_AS_STRING(hmax_b);
        for (Py_ssize_t i = 0; i < count; i++)
            if (hmax[atoms[i]] > result) result = hmax[atoms[i]];
    }
done:
    free(heap);
    return PyFloat_FromDouble(result);
}

static PyMethodDef methods[] = {
    {"pair_table", pair_table, METH_VARARGS, "h² of every pair of atoms, as n * n doubles."},
    {"pair_cost", pair_cost, METH_VARARGS, "h² of a condition: its costliest pair of atoms."},
    {"bit_lists", bit_lists, METH_VARARGS, "Per atom, the positions of the bits of its mask."},
    {"landmark_sum", landmark_sum, METH_VARARGS, "The landmark sum of a condition."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_cheap", "The cheap estimates of a condition in C.", -1,
                                    methods};

PyMODINIT_FUNC PyInit__cheap(void) { return PyModule_Create(&module); }
