// The per-step reads of acc_fusion.sumo.SumoSource as one call into libsumo's C++ API.
//
// Built on first use by acc_fusion/native.py against the headers of the eclipse-sumo wheel and
// linked to the libsumo wheel's _libsumo.so, which the Python process has already loaded, so
// the calls reach the same (embedded) simulation as libsumo's Python functions.  It reads
// exactly what those functions return (libsumo::Vehicle::getSpeed and getLeader); only the
// per-call cost of the Python wrapper is gone, and the leaders' codes are looked up in a C++
// table (Codes) rather than a dict, so no Python string is made per leader.
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <exception>
#include <new>
#include <string>
#include <unordered_map>
#include <utility>

#include <libsumo/Vehicle.h>

// Codes: a str -> int table with the dict methods SumoSource uses (c[k] = v, c[k], del c[k],
// get, pop, len, in), read by read() without Python objects.
typedef std::unordered_map<std::string, long long> Table;

struct Codes {
    PyObject_HEAD
    Table* table;
};

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
    if (self->table == nullptr) {
        Py_DECREF(self);
        return PyErr_NoMemory();
    }
    return reinterpret_cast<PyObject*>(self);
}

static void codes_dealloc(PyObject* self) {
    delete reinterpret_cast<Codes*>(self)->table;
    Py_TYPE(self)->tp_free(self);
}

static Py_ssize_t codes_len(PyObject* self) {
    return static_cast<Py_ssize_t>(reinterpret_cast<Codes*>(self)->table->size());
}

static PyObject* codes_getitem(PyObject* self, PyObject* key) {
    Table::iterator it;
    if (!find(reinterpret_cast<Codes*>(self), key, it)) return nullptr;
    if (it == reinterpret_cast<Codes*>(self)->table->end()) {
        PyErr_SetObject(PyExc_KeyError, key);
        return nullptr;
    }
    return PyLong_FromLongLong(it->second);
}

static int codes_setitem(PyObject* self, PyObject* key, PyObject* value) {
    Table* table = reinterpret_cast<Codes*>(self)->table;
    std::string k;
    if (!key_of(key, k)) return -1;
    if (value == nullptr) {  // del c[k]
        if (table->erase(k) == 0) {
            PyErr_SetObject(PyExc_KeyError, key);
            return -1;
        }
        return 0;
    }
    const long long v = PyLong_AsLongLong(value);
    if (v == -1 && PyErr_Occurred()) return -1;
    try {
        (*table)[k] = v;
    } catch (const std::bad_alloc&) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static int codes_contains(PyObject* self, PyObject* key) {
    Table::iterator it;
    if (!find(reinterpret_cast<Codes*>(self), key, it)) return -1;
    return it != reinterpret_cast<Codes*>(self)->table->end();
}

// get(key, default=None) and pop(key, default=None): the code, else default.
static PyObject* lookup(PyObject* self, PyObject* args, bool remove) {
    PyObject *key, *fallback = Py_None;
    if (!PyArg_ParseTuple(args, "O|O", &key, &fallback)) return nullptr;
    Codes* codes = reinterpret_cast<Codes*>(self);
    Table::iterator it;
    if (!find(codes, key, it)) return nullptr;
    if (it == codes->table->end()) {
        Py_INCREF(fallback);
        return fallback;
    }
    PyObject* out = PyLong_FromLongLong(it->second);
    if (remove && out != nullptr) codes->table->erase(it);
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

// read(vids, lookahead, codes, n_pairs, speed, dist, code) -> {i: leader id}
//
// For each vehicle id vids[i]: speed[i] = getSpeed, (leader, dist[i]) = getLeader(lookahead),
// code[i] = codes[leader] (-1 without a leader or when the leader has no code).  Returns the
// ids of the leaders whose code has no slot (code % (n_pairs + 1) == 0: SumoSource._set_code),
// by position i: the caller reads their speed and acceleration.  speed, dist: writable
// float64 buffers, code: int64, each of at least len(vids) items.
static PyObject* read(PyObject*, PyObject* args) {
    PyObject *vids, *codes;
    double lookahead;
    long long n_pairs;
    Py_buffer sp, ds, cd;
    if (!PyArg_ParseTuple(args, "O!dO!Lw*w*w*", &PyList_Type, &vids, &lookahead, &CodesType,
                          &codes, &n_pairs, &sp, &ds, &cd))
        return nullptr;
    const Py_ssize_t n = PyList_GET_SIZE(vids);
    const Table& table = *reinterpret_cast<Codes*>(codes)->table;
    PyObject* out = nullptr;
    if (sp.len < n * 8 || ds.len < n * 8 || cd.len < n * 8 || sp.itemsize != 8 ||
        ds.itemsize != 8 || cd.itemsize != 8) {
        PyErr_SetString(PyExc_ValueError, "read() needs 8-byte buffers of len(vids) items");
    } else if (n_pairs < 0) {
        PyErr_SetString(PyExc_ValueError, "read() needs n_pairs >= 0");
    } else if ((out = PyDict_New()) != nullptr) {
        double* speed = static_cast<double*>(sp.buf);
        double* dist = static_cast<double*>(ds.buf);
        long long* code = static_cast<long long*>(cd.buf);
        std::string id;
        try {
            for (Py_ssize_t i = 0; i < n; ++i) {
                if (!key_of(PyList_GET_ITEM(vids, i), id)) throw std::exception();
                speed[i] = libsumo::Vehicle::getSpeed(id);
                const std::pair<std::string, double> leader =
                    libsumo::Vehicle::getLeader(id, lookahead);
                dist[i] = leader.second;
                const Table::const_iterator it =
                    leader.first.empty() ? table.end() : table.find(leader.first);
                code[i] = it != table.end() ? it->second : -1;
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
        } catch (const std::exception& exc) {
            Py_CLEAR(out);
            if (!PyErr_Occurred())
                PyErr_SetString(traci_error ? traci_error : PyExc_RuntimeError, exc.what());
        }
    }
    PyBuffer_Release(&sp);
    PyBuffer_Release(&ds);
    PyBuffer_Release(&cd);
    return out;
}

static PyMethodDef methods[] = {
    {"init", init, METH_VARARGS, "init(error): the exception class a failed read raises."},
    {"read", read, METH_VARARGS,
     "read(vids, lookahead, codes, n_pairs, speed, dist, code) -> {i: leader id}: each "
     "vehicle's speed and leader (libsumo getSpeed, getLeader) into the buffers; the ids of "
     "the leaders without a slot."},
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
