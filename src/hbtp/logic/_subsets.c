/* The set-trie of hbtp.logic.subsets in C: the compiled form of SubsetIndex's Python nodes.
 *
 * The Python module documents the structure and holds the reference implementation; this file keeps
 * the same trie in flat arrays and gives the same answers (tests/test_subsets.py compares both, and
 * both with a linear scan). It is built when a C compiler is present (an optional
 * extension: without one, SubsetIndex runs in Python).
 *
 * Trie().add(atoms, value)               -- atoms: an iterable of ints in [0, 2**31); value: any
 *                                           number (kept as the Python object, compared with < and <=)
 * Trie().has_subset(atoms, at_most=None) -> bool
 *
 * A node's children are edges sorted by atom, and a query's atoms are sorted too, so a query walks
 * the fewer of the two and finds each in the other by binary search. Values are compared as
 * doubles when both are floats, as C integers when both are ints that fit, and by Python otherwise,
 * so int, float and Fraction values behave exactly as in Python.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    int32_t atom;
    int32_t node;
} Edge;

typedef struct {
    Edge *edges;
    int32_t count, room;
    PyObject *lowest; /* the smallest value stored in the subtree, or NULL */
    PyObject *here;   /* the value of the set that ends here, or NULL */
} Node;

typedef struct {
    PyObject_HEAD
    Node *nodes;
    Py_ssize_t count, room;
    int32_t *atoms; /* the sorted atoms of the set being added or queried */
    Py_ssize_t atoms_room;
    int busy; /* inside add or has_subset: a comparison in Python may let another thread in */
} Trie;

/* Refuse a call while another is under way (it would move the arrays the first is reading). */
static int enter(Trie *self) {
    if (self->busy) {
        PyErr_SetString(PyExc_RuntimeError, "a subset index is used by two calls at once");
        return -1;
    }
    self->busy = 1;
    return 0;
}

/* Python's a < b (op Py_LT) or a <= b (Py_LE): 1, 0, or -1 with an exception set. */
static int compare(PyObject *a, PyObject *b, int op) {
    if (PyFloat_CheckExact(a) && PyFloat_CheckExact(b)) {
        double x = PyFloat_AS_DOUBLE(a), y = PyFloat_AS_DOUBLE(b);
        return op == Py_LT ? x < y : x <= y;
    }
    if (PyLong_CheckExact(a) && PyLong_CheckExact(b)) {
        int over_a, over_b;
        long long x = PyLong_AsLongLongAndOverflow(a, &over_a);
        long long y = PyLong_AsLongLongAndOverflow(b, &over_b);
        if (!over_a && !over_b) return op == Py_LT ? x < y : x <= y;
    }
    return PyObject_RichCompareBool(a, b, op);
}

static int cmp_atoms(const void *a, const void *b) {
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* ``items`` reallocated to ``room`` items of ``size`` bytes, or NULL (memory error set; ``items`` kept). */
static void *grown(void *items, Py_ssize_t room, size_t size) {
    void *moved = PyMem_Realloc(items, (size_t)room * size);
    if (moved == NULL) PyErr_NoMemory();
    return moved;
}

/* Read ``items`` into self->atoms, sorted and without repeats; the count, or -1 on error. */
static Py_ssize_t read_atoms(Trie *self, PyObject *items) {
    PyObject *iterator = PyObject_GetIter(items), *item;
    if (iterator == NULL) return -1;
    Py_ssize_t n = 0;
    while ((item = PyIter_Next(iterator)) != NULL) {
        long atom = PyLong_AsLong(item);
        Py_DECREF(item);
        if (atom == -1 && PyErr_Occurred()) goto fail;
        if (atom < 0 || atom > INT32_MAX) {
            PyErr_Format(PyExc_ValueError, "a subset index holds atom ids in [0, 2**31), not %ld", atom);
            goto fail;
        }
        if (n == self->atoms_room) {
            Py_ssize_t room = self->atoms_room ? 2 * self->atoms_room : 64;
            int32_t *atoms = grown(self->atoms, room, sizeof(int32_t));
            if (atoms == NULL) goto fail;
            self->atoms = atoms;
            self->atoms_room = room;
        }
        self->atoms[n++] = (int32_t)atom;
    }
    Py_DECREF(iterator);
    if (PyErr_Occurred()) return -1;
    qsort(self->atoms, (size_t)n, sizeof(int32_t), cmp_atoms);
    Py_ssize_t kept = 0;
    for (Py_ssize_t i = 0; i < n; i++)
        if (kept == 0 || self->atoms[kept - 1] != self->atoms[i]) self->atoms[kept++] = self->atoms[i];
    return kept;
fail:
    Py_DECREF(iterator);
    return -1;
}

/* A new empty node's index, or -1 (memory error set). */
static Py_ssize_t new_node(Trie *self) {
    if (self->count == self->room) {
        Py_ssize_t room = self->room ? 2 * self->room : 1024;
        if (room > INT32_MAX) {
            PyErr_SetString(PyExc_MemoryError, "a subset index holds at most 2**31 nodes");
            return -1;
        }
        Node *nodes = grown(self->nodes, room, sizeof(Node));
        if (nodes == NULL) return -1;
        self->nodes = nodes;
        self->room = room;
    }
    memset(&self->nodes[self->count], 0, sizeof(Node));
    return self->count++;
}

/* The first edge of ``node`` from ``low`` on whose atom is at least ``atom``. */
static int32_t lower_bound(const Node *node, int32_t atom, int32_t low) {
    int32_t high = node->count;
    while (low < high) {
        int32_t middle = (low + high) / 2;
        if (node->edges[middle].atom < atom)
            low = middle + 1;
        else
            high = middle;
    }
    return low;
}

/* The child of node ``at`` by ``atom``, made if missing: its index, or -1 on error. */
static Py_ssize_t child_of(Trie *self, Py_ssize_t at, int32_t atom) {
    int32_t i = lower_bound(&self->nodes[at], atom, 0);
    if (i < self->nodes[at].count && self->nodes[at].edges[i].atom == atom) return self->nodes[at].edges[i].node;
    Py_ssize_t child = new_node(self); /* may move self->nodes */
    if (child < 0) return -1;
    Node *node = &self->nodes[at];
    if (node->count == node->room) {
        int32_t room = node->room ? 2 * node->room : 2;
        Edge *edges = grown(node->edges, room, sizeof(Edge));
        if (edges == NULL) return -1;
        node->edges = edges;
        node->room = room;
    }
    memmove(&node->edges[i + 1], &node->edges[i], (size_t)(node->count - i) * sizeof(Edge));
    node->edges[i].atom = atom;
    node->edges[i].node = (int32_t)child;
    node->count++;
    return child;
}

/* Set *slot to ``value`` if it is empty or ``value`` is smaller: 0, or -1 on error. */
static int keep_lower(PyObject **slot, PyObject *value) {
    if (*slot != NULL) {
        int less = compare(value, *slot, Py_LT);
        if (less <= 0) return less;
    }
    Py_INCREF(value);
    Py_XSETREF(*slot, value);
    return 0;
}

static int add(Trie *self, PyObject *items, PyObject *value) {
    Py_ssize_t n = read_atoms(self, items), at = 0;
    if (n < 0 || (self->count == 0 && new_node(self) < 0)) return -1;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (keep_lower(&self->nodes[at].lowest, value) < 0) return -1;
        at = child_of(self, at, self->atoms[i]);
        if (at < 0) return -1;
    }
    if (keep_lower(&self->nodes[at].lowest, value) < 0 || keep_lower(&self->nodes[at].here, value) < 0) return -1;
    return 0;
}

static PyObject *trie_add(Trie *self, PyObject *args) {
    PyObject *items, *value;
    if (!PyArg_ParseTuple(args, "OO:add", &items, &value) || enter(self) < 0) return NULL;
    int done = add(self, items, value);
    self->busy = 0;
    if (done < 0) return NULL;
    Py_RETURN_NONE;
}

/* The first index of the sorted atoms[low:n] whose atom is at least ``atom`` (n if none). */
static Py_ssize_t first_atom(const int32_t *atoms, Py_ssize_t low, Py_ssize_t n, int32_t atom) {
    Py_ssize_t high = n;
    while (low < high) {
        Py_ssize_t middle = low + (high - low) / 2;
        if (atoms[middle] < atom)
            low = middle + 1;
        else
            high = middle;
    }
    return low;
}

/* Whether the subtree of node ``at`` holds a set made of atoms[start:n] (valued at most ``bound``,
 * unless it is NULL): 1, 0, or -1 on error. */
static int search(const Trie *self, Py_ssize_t at, Py_ssize_t start, Py_ssize_t n, PyObject *bound) {
    const Node *node = &self->nodes[at];
    if (node->here != NULL) {
        int ok = bound == NULL ? 1 : compare(node->here, bound, Py_LE);
        if (ok != 0) return ok;
    }
    if (node->count < n - start) { /* walk the fewer of the children and the atoms left */
        Py_ssize_t index = start;
        for (int32_t e = 0; e < node->count; e++) {
            int32_t atom = node->edges[e].atom;
            index = first_atom(self->atoms, index, n, atom); /* both are sorted */
            if (index == n) break;
            if (self->atoms[index] != atom) continue;
            const Node *child = &self->nodes[node->edges[e].node];
            int ok = bound == NULL ? 1 : compare(child->lowest, bound, Py_LE);
            if (ok > 0) ok = search(self, node->edges[e].node, index + 1, n, bound);
            if (ok != 0) return ok;
        }
        return 0;
    }
    int32_t e = 0;
    for (Py_ssize_t index = start; index < n && e < node->count; index++) {
        int32_t atom = self->atoms[index];
        e = lower_bound(node, atom, e); /* both are sorted */
        if (e == node->count || node->edges[e].atom != atom) continue;
        const Node *child = &self->nodes[node->edges[e].node];
        int ok = bound == NULL ? 1 : compare(child->lowest, bound, Py_LE);
        if (ok > 0) ok = search(self, node->edges[e].node, index + 1, n, bound);
        if (ok != 0) return ok;
    }
    return 0;
}

/* has_subset once the call is entered: 1, 0, or -1 on error. */
static int has_subset(Trie *self, PyObject *items, PyObject *bound) {
    if (self->count == 0 || self->nodes[0].lowest == NULL) return 0;
    if (bound != NULL) {
        int above = compare(bound, self->nodes[0].lowest, Py_LT);
        if (above != 0) return above < 0 ? -1 : 0;
    }
    Py_ssize_t n = read_atoms(self, items);
    if (n < 0) return -1;
    return search(self, 0, 0, n, bound);
}

static PyObject *trie_has_subset(Trie *self, PyObject *args, PyObject *kwargs) {
    static char *keywords[] = {"atoms", "at_most", NULL};
    PyObject *items, *bound = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "O|O:has_subset", keywords, &items, &bound) || enter(self) < 0)
        return NULL;
    int found = has_subset(self, items, bound == Py_None ? NULL : bound);
    self->busy = 0;
    if (found < 0) return NULL;
    return PyBool_FromLong(found);
}

static int trie_init(Trie *self, PyObject *args, PyObject *kwargs) {
    if (!PyArg_ParseTuple(args, ":Trie") || (kwargs != NULL && PyDict_Size(kwargs) > 0)) {
        if (!PyErr_Occurred()) PyErr_SetString(PyExc_TypeError, "Trie() takes no arguments");
        return -1;
    }
    return 0; /* the root is made by the first add */
}

static void trie_dealloc(Trie *self) {
    for (Py_ssize_t i = 0; i < self->count; i++) {
        Py_XDECREF(self->nodes[i].lowest);
        Py_XDECREF(self->nodes[i].here);
        PyMem_Free(self->nodes[i].edges);
    }
    PyMem_Free(self->nodes);
    PyMem_Free(self->atoms);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyMethodDef trie_methods[] = {
    {"add", (PyCFunction)trie_add, METH_VARARGS, "Store a set of atoms with a value (a set stored twice keeps the smaller)."},
    {"has_subset", (PyCFunction)(void (*)(void))trie_has_subset, METH_VARARGS | METH_KEYWORDS,
     "Whether a stored set is a subset of the atoms (with a value of at most at_most)."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject TrieType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "hbtp.logic._subsets.Trie",
    .tp_basicsize = sizeof(Trie),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Atom sets with a value each, queried for subsets (see hbtp.logic.subsets).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)trie_init,
    .tp_dealloc = (destructor)trie_dealloc,
    .tp_methods = trie_methods,
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_subsets", "The subset index's set-trie in C.", -1, NULL, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__subsets(void) {
    if (PyType_Ready(&TrieType) < 0) return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) return NULL;
    Py_INCREF(&TrieType);
    if (PyModule_AddObject(m, "Trie", (PyObject *)&TrieType) < 0) {
        Py_DECREF(&TrieType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
