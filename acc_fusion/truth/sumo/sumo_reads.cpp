// The per-step reads of acc_fusion.sumo.SumoSource as one call into libsumo's C++ API.
//
// Built on first use by acc_fusion/native.py against the headers of the eclipse-sumo wheel and
// linked to the libsumo wheel's _libsumo.so, which the Python process has already loaded, so
// the calls reach the same (embedded) simulation as libsumo's Python functions.  It reads
// exactly what those functions return (libsumo::Vehicle::getSpeed and getLeader); only the
// per-call cost of the Python wrapper is gone, and the leaders' codes are looked up in a C++
// table (Codes) rather than a dict, so no Python string is made per leader.  Each slot also
// remembers its last leader's entry in that table, so that a leader seen at the step before
// costs a string comparison instead of a hash lookup.
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <climits>
#include <exception>
#include <iterator>
#include <new>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <libsumo/Vehicle.h>

// Codes: a str -> int table with the dict methods SumoSource uses (c[k] = v, c[k], del c[k],
// get, pop, len, in), read by read() without Python objects.
//
// A deleted key's entry is marked DEAD rather than erased, so that the pointers to entries
// that read() keeps per slot stay valid (an unordered_map moves no entry when it grows); the
// dead entries are erased together once there are more than max(DEAD_LIMIT, live entries),
// which also drops every kept pointer (epoch).  Memory stays bounded by the live entries.
typedef std::unordered_map<std::string, long long> Table;

static const long long DEAD = LLONG_MIN;
static const size_t DEAD_LIMIT = 1024;

// A slot's last leader: its id, the table entry of its code and the epoch it was found in.
struct Seen {
    std::string id;
    const long long* code = nullptr;
    unsigned long long epoch = 0;
};

struct Codes {
    PyObject_HEAD
    Table* table;
    std::vector<Seen>* seen;
    size_t dead;
    unsigned long long epoch;
};

static bool live(const Table::iterator& it, const Table* table) {
    return it != table->end() && it->second != DEAD;
}

// Mark an entry dead (a deleted key); erase the dead ones once there are too many.
static void kill(Codes* codes, Table::iterator it) {
    it->second = DEAD;
    if (++codes->dead <= DEAD_LIMIT || codes->dead <= codes->table->size() - codes->dead) return;
    for (Table::iterator at = codes->table->begin(); at != codes->table->end();)
        at = at->second == DEAD ? codes->table->erase(at) : std::next(at);
    codes->dead = 0;
    ++codes->epoch;  // the pointers kept by read() may point at erased entries
}

static bool key_of(PyObject* key, std::string& out) {
    Py_ssize_t len;
    const char* text = PyUnicode_AsUTF8AndSize(key, &len);
    if (text == nullptr) return false;
    out.assign(text, len);
    return true;
}

// The entry of key, or end(); false (with a Python error set) if key is not a str.
static bool find(Codes* self, PyObject* key, Table::iterator& it) {
    std::string k;
    if (!key_of(key, k)) return false;
    it = self->table->find(k);
    return true;
}

static PyObject* codes_new(PyTypeObject* type, PyObject*, PyObject*) {
    Codes* self = reinterpret_cast<Codes*>(type->tp_alloc(type, 0));
    if (self == nullptr) return nullptr;
    self->table = new (std::nothrow) Table();
    self->seen = new (std::nothrow) std::vector<Seen>();
    self->dead = 0;
    self->epoch = 0;
    if (self->table == nullptr || self->seen == nullptr) {
        Py_DECREF(self);
        return PyErr_NoMemory();
    }
    return reinterpret_cast<PyObject*>(self);
}

static void codes_dealloc(PyObject* self) {
    delete reinterpret_cast<Codes*>(self)->table;
    delete reinterpret_cast<Codes*>(self)->seen;
    Py_TYPE(self)->tp_free(self);
}

static Py_ssize_t codes_len(PyObject* self) {
    Codes* codes = reinterpret_cast<Codes*>(self);
    return static_cast<Py_ssize_t>(codes->table->size() - codes->dead);
}

static PyObject* codes_getitem(PyObject* self, PyObject* key) {
    Table::iterator it;
    if (!find(reinterpret_cast<Codes*>(self), key, it)) return nullptr;
    if (!live(it, reinterpret_cast<Codes*>(self)->table)) {
        PyErr_SetObject(PyExc_KeyError, key);
        return nullptr;
    }
    return PyLong_FromLongLong(it->second);
}

static int codes_setitem(PyObject* self, PyObject* key, PyObject* value) {
    Codes* codes = reinterpret_cast<Codes*>(self);
    std::string k;
    if (!key_of(key, k)) return -1;
    Table::iterator it = codes->table->find(k);
    if (value == nullptr) {  // del c[k]
        if (!live(it, codes->table)) {
            PyErr_SetObject(PyExc_KeyError, key);
            return -1;
        }
        kill(codes, it);
        return 0;
    }
    const long long v = PyLong_AsLongLong(value);
    if (v == -1 && PyErr_Occurred()) return -1;
    if (v == DEAD) {
        PyErr_SetString(PyExc_ValueError, "a code must be greater than the smallest int64");
        return -1;
    }
    if (it != codes->table->end()) {  // in place: the pointers to it stay valid
        if (it->second == DEAD) --codes->dead;
        it->second = v;
        return 0;
    }
    try {
        codes->table->emplace(std::move(k), v);
    } catch (const std::bad_alloc&) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static int codes_contains(PyObject* self, PyObject* key) {
    Table::iterator it;
    if (!find(reinterpret_cast<Codes*>(self), key, it)) return -1;
    return live(it, reinterpret_cast<Codes*>(self)->table);
}

// get(key, default=None) and pop(key, default=None): the code, else default.
static PyObject* lookup(PyObject* self, PyObject* args, bool remove) {
    PyObject *key, *fallback = Py_None;
    if (!PyArg_ParseTuple(args, "O|O", &key, &fallback)) return nullptr;
    Codes* codes = reinterpret_cast<Codes*>(self);
    Table::iterator it;
    if (!find(codes, key, it)) return nullptr;
    if (!live(it, codes->table)) {
        Py_INCREF(fallback);
        return fallback;
    }
    PyObject* out = PyLong_FromLongLong(it->second);
    if (remove && out != nullptr) kill(codes, it);
    return out;
}

static PyObject* codes_get(PyObject* self, PyObject* args) { return lookup(self, args, false); }
static PyObject* codes_pop(PyObject* self, PyObject* args) { return lookup(self, args, true); }

static PyMethodDef codes_methods[] = {
    {"get", codes_get, METH_VARARGS, "get(key, default=None): the code of key, else default."},
    {"pop", codes_pop, METH_VARARGS, "pop(key, default=None): remove key, returning its code."},
    {nullptr, nullptr, 0, nullptr}};

static PyMappingMethods codes_mapping = {codes_len, codes_getitem, codes_setitem};
static PySequenceMethods codes_sequence = {};

static PyTypeObject CodesType = {PyVarObject_HEAD_INIT(nullptr, 0)};

// libsumo.TraCIException, set by init(): a failed read raises what libsumo's own functions
// raise.
static PyObject* traci_error = nullptr;

static PyObject* init(PyObject*, PyObject* args) {
    PyObject* error;
    if (!PyArg_ParseTuple(args, "O", &error)) return nullptr;
    if (!PyExceptionClass_Check(error)) {
        PyErr_SetString(PyExc_TypeError, "init() needs an exception class");
        return nullptr;
    }
    Py_XDECREF(traci_error);
    Py_INCREF(error);
    traci_error = error;
    Py_RETURN_NONE;
}

// The code of leader (-1: none), through the entry its follower's slot kept (see Codes).
static long long code_of(Codes* codes, Seen& last, const std::string& leader) {
    if (leader.empty()) return -1;
    long long value = -1;
    if (last.code != nullptr && last.epoch == codes->epoch && last.id == leader) {
        value = *last.code;
    } else {
        const Table::iterator it = codes->table->find(leader);
        if (it != codes->table->end()) {
            last.id = leader;
            last.code = &it->second;
            last.epoch = codes->epoch;
            value = it->second;
        }
    }
    return value == DEAD ? -1 : value;
}

// Whether buffer b holds n items of 8 bytes.
static bool buffer_ok(const Py_buffer& b, Py_ssize_t n) {
    return b.itemsize == 8 && b.len >= n * 8;
}

// read(vids, slots, lookahead, codes, n_pairs, speed, dist, code) -> {i: leader id}
//
// For each vehicle id vids[i], in slot slots[i] (in [0, n_pairs)): speed[i] = getSpeed,
// (leader, dist[i]) = getLeader(lookahead), code[i] = codes[leader] (-1 without a leader or
// when the leader has no code).  Returns the ids of the leaders whose code has no slot
// (code % (n_pairs + 1) == 0: SumoSource._set_code), by position i: the caller reads their
// speed and acceleration.  slots: an int64 buffer; speed, dist: writable float64 buffers,
// code: int64; each of at least len(vids) items.
static PyObject* read(PyObject*, PyObject* args) {
    PyObject *vids, *table;
    double lookahead;
    long long n_pairs;
    Py_buffer sl, sp, ds, cd;
    if (!PyArg_ParseTuple(args, "O!y*dO!Lw*w*w*", &PyList_Type, &vids, &sl, &lookahead,
                          &CodesType, &table, &n_pairs, &sp, &ds, &cd))
        return nullptr;
    const Py_ssize_t n = PyList_GET_SIZE(vids);
    Codes* codes = reinterpret_cast<Codes*>(table);
    const long long* slots = static_cast<const long long*>(sl.buf);
    PyObject* out = nullptr;
    const bool buffers = buffer_ok(sl, n) && buffer_ok(sp, n) && buffer_ok(ds, n) &&
                         buffer_ok(cd, n);
    bool slots_ok = buffers && n_pairs >= 0;
    for (Py_ssize_t i = 0; slots_ok && i < n; ++i) slots_ok = slots[i] >= 0 && slots[i] < n_pairs;
    if (!buffers) {
        PyErr_SetString(PyExc_ValueError, "read() needs 8-byte buffers of len(vids) items");
    } else if (!slots_ok) {
        PyErr_SetString(PyExc_ValueError,
                        "read() needs n_pairs >= 0 and slots in [0, n_pairs)");
    } else if ((out = PyDict_New()) != nullptr) {
        double* speed = static_cast<double*>(sp.buf);
        double* dist = static_cast<double*>(ds.buf);
        long long* code = static_cast<long long*>(cd.buf);
        std::string id;
        try {
            if (codes->seen->size() < static_cast<size_t>(n_pairs)) codes->seen->resize(n_pairs);
            for (Py_ssize_t i = 0; i < n; ++i) {
                if (!key_of(PyList_GET_ITEM(vids, i), id)) throw std::exception();
                speed[i] = libsumo::Vehicle::getSpeed(id);
                const std::pair<std::string, double> leader =
                    libsumo::Vehicle::getLeader(id, lookahead);
                dist[i] = leader.second;
                code[i] = code_of(codes, (*codes->seen)[slots[i]], leader.first);
                if (code[i] >= 0 && code[i] % (n_pairs + 1) == 0) {  // a leader without a slot
                    PyObject* lid = PyUnicode_FromStringAndSize(leader.first.data(),
                                                                leader.first.size());
                    PyObject* at = PyLong_FromSsize_t(i);
                    const int failed = lid == nullptr || at == nullptr ||
                                       PyDict_SetItem(out, at, lid) < 0;
                    Py_XDECREF(lid);
                    Py_XDECREF(at);
                    if (failed) throw std::exception();
                }
            }
        } catch (const std::bad_alloc&) {
            Py_CLEAR(out);
            PyErr_NoMemory();
        } catch (const std::exception& exc) {
            Py_CLEAR(out);
            if (!PyErr_Occurred())
                PyErr_SetString(traci_error ? traci_error : PyExc_RuntimeError, exc.what());
        }
    }
    PyBuffer_Release(&sl);
    PyBuffer_Release(&sp);
    PyBuffer_Release(&ds);
    PyBuffer_Release(&cd);
    return out;
}

// state(vids, edges, f, k)
//
// For each vehicle id vids[i] (n of them): f[0n + i], f[1n + i] = getPosition (x, y: the front
// bumper's centre), f[2n + i] = getAngle, f[3n + i] = getSpeed, f[4n + i] = getAcceleration,
// f[5n + i] = getLanePosition; k[i] = edges[getRoadID] (-1 when the edge has no code),
// k[n + i] = getLaneIndex.  edges: a Codes table; f: a writable float64 buffer of 6 n items,
// k: int64 of 2 n.  The object truth of acc_fusion.truth.sumo.objects reads every vehicle so.
static PyObject* state(PyObject*, PyObject* args) {
    PyObject *vids, *table;
    Py_buffer fb, kb;
    if (!PyArg_ParseTuple(args, "O!O!w*w*", &PyList_Type, &vids, &CodesType, &table, &fb, &kb))
        return nullptr;
    const Py_ssize_t n = PyList_GET_SIZE(vids);
    const Table* edges = reinterpret_cast<Codes*>(table)->table;
    bool ok = buffer_ok(fb, 6 * n) && buffer_ok(kb, 2 * n);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError,
                        "state() needs 8-byte buffers of 6 and 2 len(vids) items");
    } else {
        double* f = static_cast<double*>(fb.buf);
        long long* k = static_cast<long long*>(kb.buf);
        std::string id;
        try {
            for (Py_ssize_t i = 0; i < n; ++i) {
                if (!key_of(PyList_GET_ITEM(vids, i), id)) throw std::exception();
                const libsumo::TraCIPosition p = libsumo::Vehicle::getPosition(id);
                f[i] = p.x;
                f[n + i] = p.y;
                f[2 * n + i] = libsumo::Vehicle::getAngle(id);
                f[3 * n + i] = libsumo::Vehicle::getSpeed(id);
                f[4 * n + i] = libsumo::Vehicle::getAcceleration(id);
                f[5 * n + i] = libsumo::Vehicle::getLanePosition(id);
                const Table::const_iterator it = edges->find(libsumo::Vehicle::getRoadID(id));
                k[i] = it == edges->end() || it->second == DEAD ? -1 : it->second;
                k[n + i] = libsumo::Vehicle::getLaneIndex(id);
            }
        } catch (const std::bad_alloc&) {
            ok = false;
            PyErr_NoMemory();
        } catch (const std::exception& exc) {
            ok = false;
            if (!PyErr_Occurred())
                PyErr_SetString(traci_error ? traci_error : PyExc_RuntimeError, exc.what());
        }
    }
    PyBuffer_Release(&fb);
    PyBuffer_Release(&kb);
    if (!ok) return nullptr;
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"init", init, METH_VARARGS, "init(error): the exception class a failed read raises."},
    {"read", read, METH_VARARGS,
     "read(vids, slots, lookahead, codes, n_pairs, speed, dist, code) -> {i: leader id}: "
     "each vehicle's speed and leader (libsumo getSpeed, getLeader) into the buffers; the ids "
     "of the leaders without a slot."},
    {"state", state, METH_VARARGS,
     "state(vids, edges, f, k): each vehicle's position, angle, speed, acceleration, lane "
     "position (f, 6 rows) and edge code and lane index (k, 2 rows)."},
    {nullptr, nullptr, 0, nullptr}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_sumo_reads", nullptr, -1, methods};

PyMODINIT_FUNC PyInit__sumo_reads(void) {
    CodesType.tp_name = "_sumo_reads.Codes";
    CodesType.tp_doc = "A str -> int table of leader codes, read by read() in C++.";
    CodesType.tp_basicsize = sizeof(Codes);
    CodesType.tp_flags = Py_TPFLAGS_DEFAULT;
    CodesType.tp_new = codes_new;
    CodesType.tp_dealloc = codes_dealloc;
    CodesType.tp_as_mapping = &codes_mapping;
    codes_sequence.sq_contains = codes_contains;
    CodesType.tp_as_sequence = &codes_sequence;
    CodesType.tp_methods = codes_methods;
    if (PyType_Ready(&CodesType) < 0) return nullptr;
    PyObject* m = PyModule_Create(&module);
    if (m == nullptr) return nullptr;
    Py_INCREF(&CodesType);
    if (PyModule_AddObject(m, "Codes", reinterpret_cast<PyObject*>(&CodesType)) < 0) {
        Py_DECREF(&CodesType);
        Py_DECREF(m);
        return nullptr;
    }
    return m;
}
