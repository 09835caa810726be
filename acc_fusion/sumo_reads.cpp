// The per-step reads of acc_fusion.sumo.SumoSource as one call into libsumo's C++ API.
//
// Built on first use by acc_fusion/native.py against the headers of the eclipse-sumo wheel and
// linked to the libsumo wheel's _libsumo.so, which the Python process has already loaded, so
// the calls reach the same (embedded) simulation as libsumo's Python functions.  It reads
// exactly what those functions return (libsumo::Vehicle::getSpeed and getLeader); only the
// per-call cost of the Python wrapper is gone.
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <exception>
#include <string>
#include <utility>

#include <libsumo/Vehicle.h>

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

// read(vids, lookahead, codes, speed, dist, code) -> list of leader ids
//
// For each vehicle id vids[i]: speed[i] = getSpeed, (leader, dist[i]) = getLeader(lookahead),
// code[i] = codes[leader] (-1 without a leader or when the leader has no code).  Returns the
// leader ids ("" without a leader).  speed, dist: writable float64 buffers, code: int64,
// each of at least len(vids) items.
static PyObject* read(PyObject*, PyObject* args) {
    PyObject *vids, *codes;
    double lookahead;
    Py_buffer sp, ds, cd;
    if (!PyArg_ParseTuple(args, "O!dO!w*w*w*", &PyList_Type, &vids, &lookahead, &PyDict_Type,
                          &codes, &sp, &ds, &cd))
        return nullptr;
    const Py_ssize_t n = PyList_GET_SIZE(vids);
    PyObject* out = nullptr;
    if (sp.len < n * 8 || ds.len < n * 8 || cd.len < n * 8 || sp.itemsize != 8 ||
        ds.itemsize != 8 || cd.itemsize != 8) {
        PyErr_SetString(PyExc_ValueError, "read() needs 8-byte buffers of len(vids) items");
    } else if ((out = PyList_New(n)) != nullptr) {
        double* speed = static_cast<double*>(sp.buf);
        double* dist = static_cast<double*>(ds.buf);
        long long* code = static_cast<long long*>(cd.buf);
        std::string id;
        try {
            for (Py_ssize_t i = 0; i < n; ++i) {
                Py_ssize_t len;
                const char* text = PyUnicode_AsUTF8AndSize(PyList_GET_ITEM(vids, i), &len);
                if (text == nullptr) throw std::exception();
                id.assign(text, len);
                speed[i] = libsumo::Vehicle::getSpeed(id);
                const std::pair<std::string, double> leader =
                    libsumo::Vehicle::getLeader(id, lookahead);
                dist[i] = leader.second;
                PyObject* lid = PyUnicode_FromStringAndSize(leader.first.data(),
                                                            leader.first.size());
                if (lid == nullptr) throw std::exception();
                PyList_SET_ITEM(out, i, lid);
                PyObject* c = leader.first.empty() ? nullptr : PyDict_GetItemWithError(codes, lid);
                code[i] = c != nullptr ? PyLong_AsLongLong(c) : -1;
                if (PyErr_Occurred()) throw std::exception();
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
     "read(vids, lookahead, codes, speed, dist, code) -> leader ids: each vehicle's speed and "
     "leader (libsumo getSpeed, getLeader) into the buffers."},
    {nullptr, nullptr, 0, nullptr}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_sumo_reads", nullptr, -1, methods};

PyMODINIT_FUNC PyInit__sumo_reads(void) { return PyModule_Create(&module); }
