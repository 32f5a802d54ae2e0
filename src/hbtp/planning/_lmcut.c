/* One round of LM-cut in C: the compiled form of hbtp.planning.lmcut._Round.cut.
 *
 * The Python module documents the algorithm and holds the reference implementation; this file does
 * the same steps in the same order over flat arrays (array.array buffers), so that both give the
 * same values to the last bit (tests/test_lmcut.py compares them). It is built when a C compiler is
 * present (an optional extension: without one, hbtp runs the Python round).
 *
 * cut(pre_start, pre, add_start, add, users_start, users, ach_start, ach,   -- int32, read only
 *     hmax, value, choice, cost,                                             -- state, updated
 *     top) -> the cost the round adds to the estimate
 *
 * The static arrays are compressed rows: action i's preconditions are pre[pre_start[i] ..
 * pre_start[i + 1]), and so on for add effects (by action), users and achievers (by atom).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>

typedef struct {
    const int32_t *start;
    const int32_t *item;
} Rows;

typedef struct {
    Rows pre, add, users, ach;
    Py_ssize_t atoms, actions;
    double *hmax, *value, *cost;
    int32_t *choice;
} Task;

typedef struct {
    double v;
    int32_t q;
} Entry;

typedef struct {
    Entry *items;
    Py_ssize_t size, room;
} Heap;

static int entry_less(Entry a, Entry b) { return a.v < b.v || (a.v == b.v && a.q < b.q); }

static int heap_push(Heap *h, double v, int32_t q) {
    if (h->size == h->room) {
        Py_ssize_t room = h->room ? 2 * h->room : 64;
        Entry *items = realloc(h->items, (size_t)room * sizeof(Entry));
        if (items == NULL) return -1;
        h->items = items;
        h->room = room;
    }
    Py_ssize_t i = h->size++;
    Entry e = {v, q};
    while (i > 0) {
        Py_ssize_t parent = (i - 1) / 2;
        if (!entry_less(e, h->items[parent])) break;
        h->items[i] = h->items[parent];
        i = parent;
    }
    h->items[i] = e;
    return 0;
}

static Entry heap_pop(Heap *h) {
    Entry top = h->items[0];
    Entry last = h->items[--h->size];
    Py_ssize_t i = 0, n = h->size;
    while (1) {
        Py_ssize_t child = 2 * i + 1;
        if (child >= n) break;
        if (child + 1 < n && entry_less(h->items[child + 1], h->items[child])) child++;
        if (!entry_less(h->items[child], last)) break;
        h->items[i] = h->items[child];
        i = child;
    }
    if (n > 0) h->items[i] = last;
    return top;
}

/* Scratch memory of one round. */
typedef struct {
    char *zone;        /* by atom: in the goal zone */
    int8_t *known;     /* by atom: 0 not known, 1 reached outside the zone, 2 not */
    int32_t *seen;     /* by atom: the search that saw it (a stamp) */
    char *in_cut;      /* by action */
    int32_t *zone_list, *stack, *seen_list, *cut_list;
    Py_ssize_t zone_size, cut_size;
} Scratch;

static void scratch_free(Scratch *s) {
    free(s->zone);
    free(s->known);
    free(s->seen);
    free(s->in_cut);
    free(s->zone_list);
    free(s->stack);
    free(s->seen_list);
    free(s->cut_list);
}

static int scratch_alloc(Scratch *s, Py_ssize_t atoms, Py_ssize_t actions) {
    s->zone = calloc((size_t)atoms, 1);
    s->known = calloc((size_t)atoms, 1);
    s->seen = calloc((size_t)atoms, sizeof(int32_t));
    s->in_cut = calloc((size_t)actions, 1);
    s->zone_list = malloc((size_t)atoms * sizeof(int32_t));
    s->stack = malloc((size_t)atoms * sizeof(int32_t));
    s->seen_list = malloc((size_t)atoms * sizeof(int32_t));
    s->cut_list = malloc((size_t)(actions + 1) * sizeof(int32_t));
    s->zone_size = s->cut_size = 0;
    if (!s->zone || !s->known || !s->seen || !s->in_cut || !s->zone_list || !s->stack || !s->seen_list ||
        !s->cut_list) {
        scratch_free(s);
        return -1;
    }
    return 0;
}

/* The atoms from which top is reached through zero-cost achievers' precondition choices. */
static void goal_zone(const Task *t, Scratch *s, int32_t top) {
    Py_ssize_t depth = 0;
    s->zone[top] = 1;
    s->zone_list[s->zone_size++] = top;
    s->stack[depth++] = top;
    while (depth > 0) {
        int32_t q = s->stack[--depth];
        for (int32_t k = t->ach.start[q]; k < t->ach.start[q + 1]; k++) {
            int32_t i = t->ach.item[k];
            if (t->cost[i] != 0.0) continue;
            int32_t p = t->choice[i];
            if (p >= 0 && !s->zone[p]) {
                s->zone[p] = 1;
                s->zone_list[s->zone_size++] = p;
                s->stack[depth++] = p;
            }
        }
    }
}

/* Whether atom (outside the zone, h_max at least top) is reached from s0 without entering the zone;
 * a search that finds no way marks every atom it saw as not reached. */
static int8_t reached_outside(const Task *t, Scratch *s, int32_t atom, double top, int32_t stamp) {
    Py_ssize_t depth = 0, seen = 0;
    s->seen[atom] = stamp;
    s->seen_list[seen++] = atom;
    s->stack[depth++] = atom;
    while (depth > 0) {
        int32_t q = s->stack[--depth];
        for (int32_t k = t->ach.start[q]; k < t->ach.start[q + 1]; k++) {
            int32_t p = t->choice[t->ach.item[k]];
            if (p < 0 || s->zone[p] || s->seen[p] == stamp) continue;
            if (t->hmax[p] < top || s->known[p] == 1) {
                s->known[atom] = 1;
                return 1;
            }
            if (s->known[p] == 0) {
                s->seen[p] = stamp;
                s->seen_list[seen++] = p;
                s->stack[depth++] = p;
            }
        }
    }
    for (Py_ssize_t j = 0; j < seen; j++) s->known[s->seen_list[j]] = 2;
    return 2;
}

/* The cut: the zone's achievers whose precondition choice lies outside the zone and is reached
 * from s0 without entering it. */
static void cut_actions(const Task *t, Scratch *s, double top) {
    int32_t stamp = 0;
    for (Py_ssize_t z = 0; z < s->zone_size; z++) {
        int32_t q = s->zone_list[z];
        for (int32_t k = t->ach.start[q]; k < t->ach.start[q + 1]; k++) {
            int32_t i = t->ach.item[k];
            int32_t p = t->choice[i];
            if (p < 0 || s->zone[p] || s->in_cut[i]) continue;
            int8_t reached = 1;
            if (t->hmax[p] >= top) {
                reached = s->known[p];
                if (reached == 0) reached = reached_outside(t, s, p, top, ++stamp);
            }
            if (reached == 1) {
                s->in_cut[i] = 1;
                s->cut_list[s->cut_size++] = i;
            }
        }
    }
}

/* Propagate lowered h_max values to the actions whose precondition choice they are. */
static int lower(const Task *t, Heap *heap) {
    while (heap->size > 0) {
        Entry e = heap_pop(heap);
        if (e.v != t->hmax[e.q]) continue;
        for (int32_t k = t->users.start[e.q]; k < t->users.start[e.q + 1]; k++) {
            int32_t i = t->users.item[k];
            if (t->choice[i] != e.q) continue;
            int32_t first = t->pre.start[i], end = t->pre.start[i + 1];
            double best = e.v;
            if (end - first > 1) {
                int32_t arg = -1;
                best = -1.0;
                for (int32_t j = first; j < end; j++) {
                    int32_t p = t->pre.item[j];
                    if (t->hmax[p] > best) {
                        best = t->hmax[p];
                        arg = p;
                    }
                }
                t->choice[i] = arg;
            }
            if (best < t->value[i]) {
                t->value[i] = best;
                double reached = best + t->cost[i];
                for (int32_t j = t->add.start[i]; j < t->add.start[i + 1]; j++) {
                    int32_t q2 = t->add.item[j];
                    if (reached < t->hmax[q2]) {
                        t->hmax[q2] = reached;
                        if (heap_push(heap, reached, q2) < 0) return -1;
                    }
                }
            }
        }
    }
    return 0;
}

/* One round: the cut for top, its cost taken off its actions, h_max updated. Returns the cost, or a
 * negative value when memory ran out (-1) or the cut was empty (-2). */
static double round_cut(const Task *t, int32_t top) {
    Scratch s;
    Heap heap = {NULL, 0, 0};
    if (scratch_alloc(&s, t->atoms, t->actions) < 0) return -1.0;
    double ztop = t->hmax[top];
    goal_zone(t, &s, top);
    cut_actions(t, &s, ztop);
    double m = -2.0;
    for (Py_ssize_t c = 0; c < s.cut_size; c++) {
        double cost = t->cost[s.cut_list[c]];
        if (m < 0.0 || cost < m) m = cost;
    }
    for (Py_ssize_t c = 0; c < s.cut_size && m >= 0.0; c++) {
        int32_t i = s.cut_list[c];
        t->cost[i] -= m;
        double reached = t->value[i] + t->cost[i];
        for (int32_t j = t->add.start[i]; j < t->add.start[i + 1]; j++) {
            int32_t q = t->add.item[j];
            if (reached < t->hmax[q]) {
                t->hmax[q] = reached;
                if (heap_push(&heap, reached, q) < 0) m = -1.0;
            }
        }
    }
    if (m >= 0.0 && lower(t, &heap) < 0) m = -1.0;
    free(heap.items);
    scratch_free(&s);
    return m;
}

#define BUFFERS 12

static int check_sizes(Py_buffer *b, Task *t) {
    Py_ssize_t itemsize[BUFFERS] = {4, 4, 4, 4, 4, 4, 4, 4, 8, 8, 4, 8};
    for (int k = 0; k < BUFFERS; k++) {
        if (b[k].itemsize != itemsize[k]) {
            PyErr_SetString(PyExc_TypeError, "lmcut.cut: an array has the wrong item size");
            return -1;
        }
    }
    t->atoms = b[8].len / 8;
    t->actions = b[9].len / 8;
    if (b[0].len / 4 != t->actions + 1 || b[4].len / 4 != t->atoms + 1 || b[6].len / 4 != t->atoms + 1 ||
        b[10].len / 4 != t->actions || b[11].len / 8 != t->actions) {
        PyErr_SetString(PyExc_ValueError, "lmcut.cut: the arrays' lengths do not match");
        return -1;
    }
    return 0;
}

static PyObject *cut(PyObject *self, PyObject *args) {
    (void)self;
    Py_buffer b[BUFFERS];
    int top;
    memset(b, 0, sizeof(b));
    if (!PyArg_ParseTuple(args, "y*y*y*y*y*y*y*y*w*w*w*w*i", &b[0], &b[1], &b[2], &b[3], &b[4], &b[5], &b[6],
                          &b[7], &b[8], &b[9], &b[10], &b[11], &top))
        return NULL;
    Task t = {{b[0].buf, b[1].buf}, {b[2].buf, b[3].buf}, {b[4].buf, b[5].buf}, {b[6].buf, b[7].buf}, 0, 0,
              b[8].buf, b[9].buf, b[11].buf, b[10].buf};
    double m = 0.0;
    int ok = check_sizes(b, &t) == 0;
    if (ok && (top < 0 || top >= t.atoms)) {
        PyErr_SetString(PyExc_IndexError, "lmcut.cut: the atom is out of range");
        ok = 0;
    }
    if (ok) {
        Py_BEGIN_ALLOW_THREADS m = round_cut(&t, (int32_t)top);
        Py_END_ALLOW_THREADS
    }
    for (int k = 0; k < BUFFERS; k++) PyBuffer_Release(&b[k]);
    if (!ok) return NULL;
    if (m == -1.0) return PyErr_NoMemory();
    if (m < 0.0) {
        PyErr_SetString(PyExc_RuntimeError, "lmcut.cut: the cut is empty");
        return NULL;
    }
    return PyFloat_FromDouble(m);
}

static PyMethodDef methods[] = {
    {"cut", cut, METH_VARARGS, "One LM-cut round over flat arrays (see hbtp.planning.lmcut)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_lmcut", "LM-cut rounds in C.", -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__lmcut(void) { return PyModule_Create(&module); }
