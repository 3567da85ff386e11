//! The CPython module `tide._tide`: a thin wrapper over MemorySceneSource + RenderIndex +
//! RenderDelegate speaking the delegate protocol. Every C++ exception becomes a Python
//! exception (`tide._tide.TideError`, or TypeError/ValueError for bad arguments); the GIL is
//! released around long calls, and never re-acquired while the scene lock is held.
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "tide/preview.h"
#include "tide/prims.h"
#include "tide/renderDelegate.h"
#include "tide/renderIndex.h"
#include "tide/renderParam.h"
#include "tide/texture.h"
#include "tide/vdb.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

PyObject* g_error = nullptr;

/// Raised as ValueError / TypeError instead of TideError.
struct ArgError : std::runtime_error {
    PyObject* type;
    ArgError(PyObject* t, const std::string& m) : std::runtime_error(m), type(t) {}
};

PyObject* Raise(const std::exception& e) {
    if (auto* a = dynamic_cast<const ArgError*>(&e)) {
        PyErr_SetString(a->type, a->what());
    } else {
        PyErr_SetString(g_error, e.what());
    }
    return nullptr;
}

#define TIDE_TRY try {
#define TIDE_CATCH                                                     \
    }                                                                  \
    catch (const std::exception& e) {                                  \
        if (PyErr_Occurred()) return nullptr;                          \
        return Raise(e);                                               \
    }                                                                  \
    catch (...) {                                                      \
        PyErr_SetString(g_error, "unknown C++ exception");             \
        return nullptr;                                                \
    }

struct PythonError : std::runtime_error {
    PythonError() : std::runtime_error("python error") {}
};

template <typename F>
auto WithoutGil(F&& f) -> decltype(f()) {
    PyThreadState* saved = PyEval_SaveThread();
    try {
        auto r = f();
        PyEval_RestoreThread(saved);
        return r;
    } catch (...) {
        PyEval_RestoreThread(saved);
        throw;
    }
}

std::string ToString(PyObject* o, const char* what) {
    if (!PyUnicode_Check(o)) throw ArgError(PyExc_TypeError, std::string(what) + " must be a str");
    Py_ssize_t n = 0;
    const char* s = PyUnicode_AsUTF8AndSize(o, &n);
    if (!s) throw PythonError();
    return std::string(s, size_t(n));
}

bool ParseTime(PyObject* o, bool* has, double* t) {
    *has = false;
    if (!o || o == Py_None) return true;
    *t = PyFloat_AsDouble(o);
    if (*t == -1.0 && PyErr_Occurred()) return false;
    if (!std::isfinite(*t)) throw ArgError(PyExc_ValueError, "time must be finite");
    *has = true;
    return true;
}

// ---------------------------------------------------------------------------------------------
// Numbers from buffers and sequences

/// Numbers read from any Python buffer or sequence, as doubles plus whether they were integers.
struct Numbers {
    std::vector<double> values;
    bool integral = false;
};

bool FormatIsIntegral(char c) { return std::strchr("bBhHiIlLqQ?", c) != nullptr; }

Numbers ReadNumbers(PyObject* obj, char rawKind) {
    Numbers out;
    if (PyObject_CheckBuffer(obj)) {
        Py_buffer view;
        if (PyObject_GetBuffer(obj, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) != 0) throw PythonError();
        std::unique_ptr<Py_buffer, void (*)(Py_buffer*)> guard(&view, PyBuffer_Release);
        const char* fmt = view.format ? view.format : "B";
        if (*fmt == '<' || *fmt == '>' || *fmt == '=' || *fmt == '@' || *fmt == '!') {
            if (*fmt == '>' || *fmt == '!') throw ArgError(PyExc_ValueError, "big-endian buffers are not supported");
            ++fmt;
        }
        if (std::strlen(fmt) != 1) throw ArgError(PyExc_TypeError, std::string("unsupported buffer format '") + fmt + "'");
        const char c = fmt[0];
        const size_t n = size_t(view.len / view.itemsize);
        const char* p = static_cast<const char*>(view.buf);
        if ((c == 'B' || c == 'c') && view.itemsize == 1 && rawKind != 0) {
            // Plain bytes: native-endian elements of the requested kind.
            const size_t size = rawKind == 'd' ? 8 : 4;
            if (size_t(view.len) % size != 0)
                throw ArgError(PyExc_ValueError, "byte buffer length is not a multiple of the element size");
            const size_t m = size_t(view.len) / size;
            out.values.resize(m);
            out.integral = rawKind == 'i';
            for (size_t i = 0; i < m; ++i) {
                if (rawKind == 'f') { float v; std::memcpy(&v, p + i * 4, 4); out.values[i] = v; }
                else if (rawKind == 'd') { double v; std::memcpy(&v, p + i * 8, 8); out.values[i] = v; }
                else { int32_t v; std::memcpy(&v, p + i * 4, 4); out.values[i] = v; }
            }
            return out;
        }
        out.values.resize(n);
        out.integral = FormatIsIntegral(c);
        for (size_t i = 0; i < n; ++i) {
            const char* q = p + i * size_t(view.itemsize);
#define TIDE_READ(T) { T v; std::memcpy(&v, q, sizeof(T)); out.values[i] = double(v); break; }
            switch (c) {
            case 'f': TIDE_READ(float)
            case 'd': TIDE_READ(double)
            case 'b': TIDE_READ(int8_t)
            case 'B': TIDE_READ(uint8_t)
            case '?': TIDE_READ(bool)
            case 'h': TIDE_READ(int16_t)
            case 'H': TIDE_READ(uint16_t)
            case 'i': TIDE_READ(int32_t)
            case 'I': TIDE_READ(uint32_t)
            case 'l': case 'q':
                if (view.itemsize == 8) TIDE_READ(int64_t) else TIDE_READ(int32_t)
            case 'L': case 'Q':
                if (view.itemsize == 8) TIDE_READ(uint64_t) else TIDE_READ(uint32_t)
            default:
                throw ArgError(PyExc_TypeError, std::string("unsupported buffer format '") + c + "'");
            }
#undef TIDE_READ
        }
        return out;
    }
    PyObject* seq = PySequence_Fast(obj, "expected a buffer (array.array, bytes, memoryview, numpy) or a sequence of numbers");
    if (!seq) throw PythonError();
    std::unique_ptr<PyObject, void (*)(PyObject*)> guard(seq, [](PyObject* o) { Py_DECREF(o); });
    const Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    out.values.resize(size_t(n));
    out.integral = true;
    for (Py_ssize_t i = 0; i < n; ++i) {
        PyObject* item = PySequence_Fast_GET_ITEM(seq, i);
        if (PyLong_Check(item)) {
            out.values[size_t(i)] = double(PyLong_AsLongLong(item));
        } else {
            out.integral = false;
            out.values[size_t(i)] = PyFloat_AsDouble(item);
        }
        if (PyErr_Occurred()) throw PythonError();
    }
    return out;
}

std::vector<int32_t> ToInts(const Numbers& n, const char* what) {
    if (!n.integral && !n.values.empty())
        throw ArgError(PyExc_TypeError, std::string(what) + ": integers expected, got floating-point data");
    std::vector<int32_t> out(n.values.size());
    for (size_t i = 0; i < out.size(); ++i) {
        const double v = n.values[i];
        if (v < double(std::numeric_limits<int32_t>::min()) || v > double(std::numeric_limits<int32_t>::max()))
            throw ArgError(PyExc_ValueError, std::string(what) + ": value out of 32-bit range");
        out[i] = int32_t(v);
    }
    return out;
}

uint32_t CheckTuple(size_t count, long tuple, const char* what) {
    if (tuple < 1 || tuple > 64) throw ArgError(PyExc_ValueError, std::string(what) + ": tuple_size must be 1..64");
    if (count % size_t(tuple) != 0)
        throw ArgError(PyExc_ValueError, std::string(what) + ": " + std::to_string(count) +
                                             " values do not split into tuples of " + std::to_string(tuple));
    return uint32_t(tuple);
}

tide::Value ArrayValue(PyObject* buffer, long tuple, const std::string& kind, const char* what) {
    if (kind != "f" && kind != "d" && kind != "i")
        throw ArgError(PyExc_ValueError, std::string(what) + ": kind must be 'f', 'd' or 'i'");
    Numbers n = ReadNumbers(buffer, kind[0]);
    const uint32_t t = CheckTuple(n.values.size(), tuple, what);
    if (kind == "i") return tide::Value::MakeInts(ToInts(n, what));
    if (kind == "d") return tide::Value::MakeDoubles(n.values, t);
    return tide::Value::MakeFloats(std::vector<float>(n.values.begin(), n.values.end()), t);
}

tide::Value ScalarValue(PyObject* v) {
    if (PyBool_Check(v)) return tide::Value::MakeBool(v == Py_True);
    if (PyLong_Check(v)) {
        long long x = PyLong_AsLongLong(v);
        if (x == -1 && PyErr_Occurred()) throw PythonError();
        return tide::Value::MakeInt(x);
    }
    if (PyFloat_Check(v)) return tide::Value::MakeFloat(PyFloat_AsDouble(v));
    if (PyUnicode_Check(v)) return tide::Value::MakeString(ToString(v, "value"));
    if (PyTuple_Check(v) && PyTuple_GET_SIZE(v) == 2 && PyUnicode_Check(PyTuple_GET_ITEM(v, 0))) {
        const std::string tag = ToString(PyTuple_GET_ITEM(v, 0), "tag");
        PyObject* x = PyTuple_GET_ITEM(v, 1);
        if (tag == "token") return tide::Value::MakeToken(ToString(x, "token"));
        if (tag == "asset") return tide::Value::MakeAsset(ToString(x, "asset"));
        if (tag == "path") return tide::Value::MakePath(ToString(x, "path"));
        if (tag == "string") return tide::Value::MakeString(ToString(x, "string"));
        if (tag == "paths") {
            PyObject* seq = PySequence_Fast(x, "('paths', ...) needs a sequence of str");
            if (!seq) throw PythonError();
            std::unique_ptr<PyObject, void (*)(PyObject*)> guard(seq, [](PyObject* o) { Py_DECREF(o); });
            std::vector<std::string> paths;
            for (Py_ssize_t i = 0; i < PySequence_Fast_GET_SIZE(seq); ++i)
                paths.push_back(ToString(PySequence_Fast_GET_ITEM(seq, i), "path"));
            return tide::Value::MakePaths(std::move(paths));
        }
        throw ArgError(PyExc_ValueError, "unknown value tag '" + tag + "' (token, asset, path, paths, string)");
    }
    if (PyIndex_Check(v)) {
        long long x = PyLong_AsLongLong(v);
        if (x == -1 && PyErr_Occurred()) throw PythonError();
        return tide::Value::MakeInt(x);
    }
    if (PyNumber_Check(v)) {
        double x = PyFloat_AsDouble(v);
        if (x == -1.0 && PyErr_Occurred()) throw PythonError();
        return tide::Value::MakeFloat(x);
    }
    throw ArgError(PyExc_TypeError,
                   "set() takes bool, int, float, str or a tagged tuple like ('token', 'x'); use set_array / "
                   "set_matrix for arrays");
}

// ---------------------------------------------------------------------------------------------
// RenderDelegate

struct State {
    std::mutex mutex;
    tide::MemorySceneSource source;
    std::unique_ptr<tide::RenderDelegate> delegate{new tide::RenderDelegate()};
    std::unique_ptr<tide::RenderIndex> index{new tide::RenderIndex(delegate.get(), &source)};
    ~State() {
        index.reset();
        delegate.reset();
    }
};

struct PyDelegate {
    PyObject_HEAD State* state;
};

struct PyPass {
    PyObject_HEAD PyObject* owner;
    std::shared_ptr<tide::RenderPass>* pass;
};

PyTypeObject PyDelegateType = {PyVarObject_HEAD_INIT(nullptr, 0)};
PyTypeObject PyPassType = {PyVarObject_HEAD_INIT(nullptr, 0)};

State& S(PyObject* self) { return *reinterpret_cast<PyDelegate*>(self)->state; }

PyObject* Delegate_new(PyTypeObject* type, PyObject*, PyObject*) {
    TIDE_TRY
    PyObject* self = type->tp_alloc(type, 0);
    if (!self) return nullptr;
    reinterpret_cast<PyDelegate*>(self)->state = nullptr;
    try {
        reinterpret_cast<PyDelegate*>(self)->state = new State();
    } catch (...) {
        Py_DECREF(self);
        throw;
    }
    return self;
    TIDE_CATCH
}

void Delegate_dealloc(PyObject* self) {
    State* s = reinterpret_cast<PyDelegate*>(self)->state;
    if (s) {
        // Joining render threads may take a moment: let other Python threads run.
        Py_BEGIN_ALLOW_THREADS
        try {
            delete s;
        } catch (...) {
        }
        Py_END_ALLOW_THREADS
    }
    Py_TYPE(self)->tp_free(self);
}

PyObject* CreatePrim(PyObject* self, PyObject* args, const std::vector<std::string>& (tide::RenderDelegate::*list)() const,
                     const char* kind) {
    const char* type = nullptr;
    const char* path = nullptr;
    if (!PyArg_ParseTuple(args, "ss", &type, &path)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    std::lock_guard<std::mutex> lock(s.mutex);
    const auto& supported = (s.delegate.get()->*list)();
    bool ok = false;
    if (std::find(supported.begin(), supported.end(), std::string(type)) == supported.end()) {
        s.delegate->GetRenderParam()->AddProblem(path, "", std::string("unknown ") + kind + " type '" + type + "'");
    } else {
        s.source.Remove(path);
        ok = s.index->InsertPrim(type, path);
    }
    return PyBool_FromLong(ok);
    TIDE_CATCH
}

PyObject* Delegate_create_rprim(PyObject* self, PyObject* args) {
    return CreatePrim(self, args, &tide::RenderDelegate::GetSupportedRprimTypes, "rprim");
}
PyObject* Delegate_create_sprim(PyObject* self, PyObject* args) {
    return CreatePrim(self, args, &tide::RenderDelegate::GetSupportedSprimTypes, "sprim");
}
PyObject* Delegate_create_bprim(PyObject* self, PyObject* args) {
    return CreatePrim(self, args, &tide::RenderDelegate::GetSupportedBprimTypes, "bprim");
}

PyObject* Delegate_destroy_prim(PyObject* self, PyObject* args) {
    const char* path = nullptr;
    if (!PyArg_ParseTuple(args, "s", &path)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    bool existed = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.source.Remove(path);
        return s.index->RemovePrim(path);
    });
    return PyBool_FromLong(existed);
    TIDE_CATCH
}

/// Stores a value and marks the prim dirty; TideError if there is no such prim.
void Store(State& s, const std::string& path, const std::string& key, tide::Value v, bool hasTime, double time) {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (!s.index->HasPrim(path)) throw std::runtime_error(path + ": no such prim (create it first)");
    tide::TimedValue tv;
    tv.hasTime = hasTime;
    tv.time = time;
    tv.value = std::move(v);
    s.source.Set(path, key, std::move(tv));
    s.index->MarkAttributeDirty(path, key);
}

PyObject* Delegate_set(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "key", "value", "time", nullptr};
    const char* path = nullptr;
    const char* key = nullptr;
    PyObject* value = nullptr;
    PyObject* time = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "ssO|O", const_cast<char**>(names), &path, &key, &value, &time))
        return nullptr;
    TIDE_TRY
    bool has = false;
    double t = 0;
    if (!ParseTime(time, &has, &t)) return nullptr;
    Store(S(self), path, key, ScalarValue(value), has, t);
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_set_array(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "key", "buffer", "tuple_size", "kind", "time", nullptr};
    const char* path = nullptr;
    const char* key = nullptr;
    PyObject* buffer = nullptr;
    long tuple = 1;
    const char* kind = "f";
    PyObject* time = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "ssO|lsO", const_cast<char**>(names), &path, &key, &buffer, &tuple,
                                     &kind, &time))
        return nullptr;
    TIDE_TRY
    bool has = false;
    double t = 0;
    if (!ParseTime(time, &has, &t)) return nullptr;
    tide::Value v = ArrayValue(buffer, tuple, kind, key);
    Store(S(self), path, key, std::move(v), has, t);
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_set_matrix(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "key", "matrix", "time", nullptr};
    const char* path = nullptr;
    const char* key = nullptr;
    PyObject* m = nullptr;
    PyObject* time = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "ssO|O", const_cast<char**>(names), &path, &key, &m, &time))
        return nullptr;
    TIDE_TRY
    bool has = false;
    double t = 0;
    if (!ParseTime(time, &has, &t)) return nullptr;
    std::vector<double> flat;
    // Accept 16 numbers, or 4 rows of 4 (e.g. a Gf.Matrix4d).
    if (!PyObject_CheckBuffer(m) && PySequence_Check(m) && PySequence_Size(m) == 4) {
        for (Py_ssize_t r = 0; r < 4; ++r) {
            PyObject* row = PySequence_GetItem(m, r);
            if (!row) throw PythonError();
            std::unique_ptr<PyObject, void (*)(PyObject*)> guard(row, [](PyObject* o) { Py_DECREF(o); });
            Numbers n = ReadNumbers(row, 'd');
            flat.insert(flat.end(), n.values.begin(), n.values.end());
        }
    } else {
        flat = ReadNumbers(m, 'd').values;
    }
    if (flat.size() != 16) throw ArgError(PyExc_ValueError, std::string(key) + ": a matrix needs 16 values");
    std::array<double, 16> a{};
    std::copy(flat.begin(), flat.end(), a.begin());
    Store(S(self), path, key, tide::Value::MakeMatrix(a), has, t);
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_set_primvar(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "name", "interpolation", "buffer", "tuple_size", "indices", "kind", nullptr};
    const char* path = nullptr;
    const char* name = nullptr;
    const char* interp = nullptr;
    PyObject* buffer = nullptr;
    long tuple = 1;
    PyObject* indices = Py_None;
    const char* kind = nullptr;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "sssO|lOz", const_cast<char**>(names), &path, &name, &interp, &buffer,
                                     &tuple, &indices, &kind))
        return nullptr;
    TIDE_TRY
    const std::string in = interp;
    if (in != "constant" && in != "uniform" && in != "varying" && in != "vertex" && in != "faceVarying" && in != "instance")
        throw ArgError(PyExc_ValueError,
                       "unknown interpolation '" + in + "' (constant, uniform, varying, vertex, faceVarying, instance)");
    tide::Primvar pv;
    pv.interpolation = in;
    if (kind && *kind) {
        pv.data = ArrayValue(buffer, tuple, kind, name);
    } else {
        Numbers n = ReadNumbers(buffer, 'f');
        const uint32_t t = CheckTuple(n.values.size(), tuple, name);
        if (n.integral && PyObject_CheckBuffer(buffer))
            pv.data = tide::Value::MakeInts(ToInts(n, name));
        else
            pv.data = tide::Value::MakeFloats(std::vector<float>(n.values.begin(), n.values.end()), t);
    }
    pv.data.tuple = pv.data.type == tide::ValueType::Ints ? uint32_t(tuple) : pv.data.tuple;
    if (indices != Py_None) {
        pv.indexed = true;
        pv.indices = ToInts(ReadNumbers(indices, 'i'), "indices");
    }
    State& s = S(self);
    std::lock_guard<std::mutex> lock(s.mutex);
    if (!s.index->HasPrim(path)) throw std::runtime_error(std::string(path) + ": no such prim (create it first)");
    s.source.SetPrimvar(path, name, std::move(pv));
    s.index->MarkPrimvarDirty(path);
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_load_texture(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"asset_path", nullptr};
    const char* asset = nullptr;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "s", const_cast<char**>(names), &asset)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    std::string error;
    bool ok = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        return tide::SendTexture(*s.delegate->GetRenderParam(), asset, &error);
    });
    if (!ok) {
        PyErr_SetString(PyExc_OSError, error.c_str());
        return nullptr;
    }
    Py_RETURN_TRUE;
    TIDE_CATCH
}

PyObject* Delegate_load_vdb(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"asset_path", "field_name", "field_index", "reload", nullptr};
    const char* asset = nullptr;
    const char* field = nullptr;
    long long index = 0;
    int reload = 0;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "ss|Lp", const_cast<char**>(names), &asset, &field, &index, &reload)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    bool ok = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        return tide::LoadVdbFor(*s.delegate->GetRenderParam(), asset, field, int64_t(index), reload != 0);
    });
    return PyBool_FromLong(ok);
    TIDE_CATCH
}

/// write_vdb(path, [(name, kind, (nx, ny, nz), float32 bytes, voxel_size, (tx, ty, tz), (ox, oy, oz))])
PyObject* Module_write_vdb(PyObject*, PyObject* args) {
    const char* path = nullptr;
    PyObject* list = nullptr;
    if (!PyArg_ParseTuple(args, "sO!", &path, &PyList_Type, &list)) return nullptr;
    std::vector<tide::VdbWriteGrid> grids;
    for (Py_ssize_t i = 0; i < PyList_Size(list); ++i) {
        tide::VdbWriteGrid g;
        const char* name = nullptr;
        const char* kind = nullptr;
        Py_buffer buf;
        unsigned int d0, d1, d2;
        double tx, ty, tz;
        int o0, o1, o2;
        if (!PyArg_ParseTuple(PyList_GetItem(list, i), "ss(III)y*d(ddd)(iii)", &name, &kind, &d0, &d1, &d2, &buf,
                              &g.voxelSize, &tx, &ty, &tz, &o0, &o1, &o2))
            return nullptr;
        g.name = name;
        g.kind = kind;
        g.dims[0] = d0;
        g.dims[1] = d1;
        g.dims[2] = d2;
        g.translation[0] = tx;
        g.translation[1] = ty;
        g.translation[2] = tz;
        g.origin[0] = o0;
        g.origin[1] = o1;
        g.origin[2] = o2;
        g.values.resize(size_t(buf.len) / sizeof(float));
        std::memcpy(g.values.data(), buf.buf, g.values.size() * sizeof(float));
        PyBuffer_Release(&buf);
        grids.push_back(std::move(g));
    }
    std::string error;
    bool ok = WithoutGil([&] { return tide::WriteVdbGrids(path, grids, &error); });
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, error.c_str());
        return nullptr;
    }
    Py_RETURN_NONE;
}

PyObject* BufferTuple(uint32_t w, uint32_t h, uint32_t c, const float* data, size_t n) {
    return Py_BuildValue("(IIIy#)", w, h, c, reinterpret_cast<const char*>(data), Py_ssize_t(n * sizeof(float)));
}

PyObject* Delegate_texture_pixels(PyObject* self, PyObject* args) {
    const char* asset = nullptr;
    if (!PyArg_ParseTuple(args, "s", &asset)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    tide::rs::MappedBuffer m = s.delegate->GetRenderParam()->GetDelegate().texture_pixels(asset);
    return BufferTuple(m.width, m.height, m.channels, m.pixels.data(), m.pixels.size());
    TIDE_CATCH
}

PyObject* Delegate_grid_values(PyObject* self, PyObject* args) {
    const char* asset = nullptr;
    const char* field = nullptr;
    long long index = 0;
    if (!PyArg_ParseTuple(args, "ss|L", &asset, &field, &index)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    tide::rs::MappedBuffer m = s.delegate->GetRenderParam()->GetDelegate().grid_values(asset, field, int64_t(index));
    return BufferTuple(m.width, m.height, m.channels, m.pixels.data(), m.pixels.size());
    TIDE_CATCH
}

PyObject* ProblemList(const std::vector<tide::Problem>& problems) {
    PyObject* list = PyList_New(0);
    if (!list) return nullptr;
    for (const auto& p : problems) {
        PyObject* t = Py_BuildValue("(sss)", p.prim.c_str(), p.attribute.c_str(), p.message.c_str());
        if (!t || PyList_Append(list, t) != 0) {
            Py_XDECREF(t);
            Py_DECREF(list);
            return nullptr;
        }
        Py_DECREF(t);
    }
    return list;
}

/// Syncs what is dirty and commits; with `check`, then prepares the scene as a render would.
PyObject* CommitAndTakeProblems(PyObject* self, bool check) {
    TIDE_TRY
    State& s = S(self);
    std::vector<tide::Problem> problems = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.index->SyncAll();
        if (check) s.delegate->CheckRender();
        return s.delegate->TakeProblems();
    });
    return ProblemList(problems);
    TIDE_CATCH
}

PyObject* Delegate_commit_resources(PyObject* self, PyObject*) {
    return CommitAndTakeProblems(self, false);
}

PyObject* Delegate_check_render(PyObject* self, PyObject*) {
    return CommitAndTakeProblems(self, true);
}

PyObject* StringList(const std::vector<std::string>& v) {
    PyObject* list = PyList_New(Py_ssize_t(v.size()));
    if (!list) return nullptr;
    for (size_t i = 0; i < v.size(); ++i) {
        PyObject* s = PyUnicode_FromStringAndSize(v[i].data(), Py_ssize_t(v[i].size()));
        if (!s) {
            Py_DECREF(list);
            return nullptr;
        }
        PyList_SET_ITEM(list, Py_ssize_t(i), s);
    }
    return list;
}

PyObject* Delegate_last_synced(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(self);
    std::lock_guard<std::mutex> lock(s.mutex);
    return StringList(s.delegate->GetLastSynced());
    TIDE_CATCH
}

/// One of the delegate's render controls (pause, resume, stop, restart) -> bool.
template <bool (tide::RenderDelegate::*Action)()>
PyObject* Delegate_control(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(self);
    bool ok = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        return (s.delegate.get()->*Action)();
    });
    return PyBool_FromLong(ok);
    TIDE_CATCH
}

PyObject* Delegate_stop(PyObject* self, PyObject* args, PyObject* kwargs) {
    TIDE_TRY
    static const char* kw[] = {"blocking", nullptr};
    int blocking = 1;
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "|p", const_cast<char**>(kw), &blocking)) return nullptr;
    State& s = S(self);
    bool ok = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        return s.delegate->Stop(blocking != 0);
    });
    return PyBool_FromLong(ok);
    TIDE_CATCH
}

template <bool (tide::RenderDelegate::*Query)() const>
PyObject* Delegate_query(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(self);
    std::lock_guard<std::mutex> lock(s.mutex);
    return PyBool_FromLong((s.delegate.get()->*Query)());
    TIDE_CATCH
}

PyObject* Delegate_supported_types(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(self);
    PyObject* r = StringList(s.delegate->GetSupportedRprimTypes());
    PyObject* sp = StringList(s.delegate->GetSupportedSprimTypes());
    PyObject* b = StringList(s.delegate->GetSupportedBprimTypes());
    if (!r || !sp || !b) {
        Py_XDECREF(r);
        Py_XDECREF(sp);
        Py_XDECREF(b);
        return nullptr;
    }
    return Py_BuildValue("{sNsNsN}", "rprims", r, "sprims", sp, "bprims", b);
    TIDE_CATCH
}

/// A copy of a buffer's resolved pixels.
struct Resolved {
    uint32_t w = 0, h = 0, c = 0;
    std::vector<float> pixels;
};

Resolved ResolveBuffer(State& s, const std::string& path) {
    std::lock_guard<std::mutex> lock(s.mutex);
    tide::RenderBuffer* rb = s.index->GetRenderBuffer(path);
    if (!rb) throw std::runtime_error(path + ": no such render buffer");
    rb->Resolve();
    Resolved r;
    r.w = rb->GetWidth();
    r.h = rb->GetHeight();
    r.c = uint32_t(rb->GetChannels());
    const float* p = static_cast<const float*>(rb->Map());
    r.pixels.assign(p, p + size_t(r.w) * r.h * r.c);
    rb->Unmap();
    // an int32 buffer's values, as numbers
    if (rb->GetFormat() == tide::Format::Int32)
        for (float& v : r.pixels) {
            int32_t i;
            std::memcpy(&i, &v, 4);
            v = float(i);
        }
    return r;
}

PyObject* Delegate_map_buffer(PyObject* self, PyObject* args) {
    const char* path = nullptr;
    if (!PyArg_ParseTuple(args, "s", &path)) return nullptr;
    TIDE_TRY
    State& s = S(self);
    Resolved r = WithoutGil([&] { return ResolveBuffer(s, path); });
    return BufferTuple(r.w, r.h, r.c, r.pixels.data(), r.pixels.size());
    TIDE_CATCH
}

std::vector<std::pair<std::string, std::string>> Pairs(PyObject* obj, const char* what) {
    std::vector<std::pair<std::string, std::string>> out;
    if (obj == nullptr || obj == Py_None) return out;
    if (PyDict_Check(obj)) {
        PyObject *k, *v;
        Py_ssize_t pos = 0;
        while (PyDict_Next(obj, &pos, &k, &v)) {
            PyObject* ks = PyObject_Str(k);
            PyObject* vs = PyObject_Str(v);
            if (!ks || !vs) {
                Py_XDECREF(ks);
                Py_XDECREF(vs);
                throw PythonError();
            }
            std::string a = ToString(ks, what), b = ToString(vs, what);
            Py_DECREF(ks);
            Py_DECREF(vs);
            out.emplace_back(std::move(a), std::move(b));
        }
        return out;
    }
    PyObject* seq = PySequence_Fast(obj, "expected a sequence of pairs");
    if (!seq) throw PythonError();
    std::unique_ptr<PyObject, void (*)(PyObject*)> guard(seq, [](PyObject* o) { Py_DECREF(o); });
    for (Py_ssize_t i = 0; i < PySequence_Fast_GET_SIZE(seq); ++i) {
        PyObject* item = PySequence_Fast_GET_ITEM(seq, i);
        if (!PyTuple_Check(item) && !PyList_Check(item)) throw ArgError(PyExc_TypeError, std::string(what) + ": expected (str, str) pairs");
        if (PySequence_Size(item) != 2) throw ArgError(PyExc_TypeError, std::string(what) + ": expected (str, str) pairs");
        PyObject* a = PySequence_GetItem(item, 0);
        PyObject* b = PySequence_GetItem(item, 1);
        std::unique_ptr<PyObject, void (*)(PyObject*)> ga(a, [](PyObject* o) { Py_XDECREF(o); });
        std::unique_ptr<PyObject, void (*)(PyObject*)> gb(b, [](PyObject* o) { Py_XDECREF(o); });
        if (!a || !b) throw PythonError();
        out.emplace_back(ToString(a, what), ToString(b, what));
    }
    return out;
}

/// An EXR file's layers: (name, aov) or (name, aov, dataType) sequences.
rust::Vec<tide::rs::ExrLayer> Layers(PyObject* obj) {
    rust::Vec<tide::rs::ExrLayer> out;
    PyObject* seq = PySequence_Fast(obj, "layers: expected a sequence of (name, aov[, dataType])");
    if (!seq) throw PythonError();
    std::unique_ptr<PyObject, void (*)(PyObject*)> guard(seq, [](PyObject* o) { Py_DECREF(o); });
    for (Py_ssize_t i = 0; i < PySequence_Fast_GET_SIZE(seq); ++i) {
        PyObject* item = PySequence_Fast_GET_ITEM(seq, i);
        Py_ssize_t n = (PyTuple_Check(item) || PyList_Check(item)) ? PySequence_Size(item) : -1;
        if (n != 2 && n != 3) throw ArgError(PyExc_TypeError, "layers: expected (name, aov[, dataType]) tuples");
        std::string parts[3];
        for (Py_ssize_t k = 0; k < n; ++k) {
            PyObject* v = PySequence_GetItem(item, k);
            if (!v) throw PythonError();
            std::unique_ptr<PyObject, void (*)(PyObject*)> gv(v, [](PyObject* o) { Py_DECREF(o); });
            parts[k] = ToString(v, "layers");
        }
        out.push_back(tide::rs::ExrLayer{rust::String(parts[0]), rust::String(parts[1]), rust::String(parts[2])});
    }
    return out;
}

PyObject* Delegate_write_exr(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "layers", "header", nullptr};
    const char* path = nullptr;
    PyObject* layers = nullptr;
    PyObject* header = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "sO|O", const_cast<char**>(names), &path, &layers, &header))
        return nullptr;
    TIDE_TRY
    rust::Vec<tide::rs::ExrLayer> l = Layers(layers);
    rust::Vec<tide::rs::StringPair> h;
    for (auto& p : Pairs(header, "header")) h.push_back(tide::rs::StringPair{rust::String(p.first), rust::String(p.second)});
    State& s = S(self);
    WithoutGil([&] {
        s.delegate->GetRenderParam()->GetDelegate().write_exr(path, l, h);
        return 0;
    });
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_write_preview_png(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"path", "buffer_path", "color_space", "view", nullptr};
    const char* path = nullptr;
    const char* buffer = nullptr;
    const char* cs = "lin_rec709";
    const char* view = "Standard";
    if (!PyArg_ParseTupleAndKeywords(args, kw, "ss|ss", const_cast<char**>(names), &path, &buffer, &cs, &view))
        return nullptr;
    TIDE_TRY
    State& s = S(self);
    WithoutGil([&] {
        // written from the buffer's own storage, mapped while the PNG is written (no copy)
        std::lock_guard<std::mutex> lock(s.mutex);
        tide::RenderBuffer* rb = s.index->GetRenderBuffer(buffer);
        if (!rb) throw std::runtime_error(std::string(buffer) + ": no such render buffer");
        rb->Resolve();
        const float* pixels = static_cast<const float*>(rb->Map());
        std::unique_ptr<tide::RenderBuffer, void (*)(tide::RenderBuffer*)> mapped(rb, [](tide::RenderBuffer* b) { b->Unmap(); });
        std::string error;
        if (!tide::WritePreviewPng(path, int(rb->GetWidth()), int(rb->GetHeight()), rb->GetChannels(), pixels, cs, view, &error))
            throw std::runtime_error(std::string(buffer) + ": " + error);
        return 0;
    });
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Delegate_create_render_pass(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(self);
    std::shared_ptr<tide::RenderPass> pass;
    {
        std::lock_guard<std::mutex> lock(s.mutex);
        pass = s.delegate->CreateRenderPass();
    }
    PyPass* obj = PyObject_New(PyPass, &PyPassType);
    if (!obj) return nullptr;
    obj->pass = new std::shared_ptr<tide::RenderPass>(std::move(pass));
    Py_INCREF(self);
    obj->owner = self;
    return reinterpret_cast<PyObject*>(obj);
    TIDE_CATCH
}

// ---------------------------------------------------------------------------------------------
// RenderPass

tide::RenderPass& P(PyObject* self) { return **reinterpret_cast<PyPass*>(self)->pass; }

void Pass_dealloc(PyObject* self) {
    PyPass* p = reinterpret_cast<PyPass*>(self);
    if (p->pass) {
        Py_BEGIN_ALLOW_THREADS
        delete p->pass;
        Py_END_ALLOW_THREADS
    }
    Py_XDECREF(p->owner);
    PyObject_Del(self);
}

PyObject* Pass_execute(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"camera_path", "aov_bindings", "settings_path", "hydra", "projection", "clear_values", "render_tags", nullptr};
    const char* camera = nullptr;
    PyObject* bindings = nullptr;
    const char* settings = nullptr;
    int hydra = 0;
    PyObject* projection = nullptr;
    PyObject* clears = nullptr;
    PyObject* tags = nullptr;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "sO|zpOOO", const_cast<char**>(names), &camera, &bindings, &settings, &hydra, &projection, &clears, &tags))
        return nullptr;
    TIDE_TRY
    tide::RenderPassState state;
    state.camera = camera;
    state.renderSettings = settings ? settings : "";
    state.hydra = hydra != 0;
    if (projection && projection != Py_None) {
        Numbers n = ReadNumbers(projection, 'd');
        if (n.values.size() != 16) throw ArgError(PyExc_ValueError, "projection: expected 16 numbers");
        state.projection.assign(n.values.begin(), n.values.end());
    }
    for (auto& b : Pairs(bindings, "aov_bindings")) state.aovBindings.push_back({b.first, b.second, nullptr, {}});
    if (tags && tags != Py_None) {
        // a sequence of tag strings
        PyObject* seq = PySequence_Fast(tags, "render_tags: expected a sequence of strings");
        if (!seq) throw PythonError();
        for (Py_ssize_t i = 0; i < PySequence_Fast_GET_SIZE(seq); ++i) {
            PyObject* t = PySequence_Fast_GET_ITEM(seq, i);
            if (!PyUnicode_Check(t)) {
                Py_DECREF(seq);
                throw ArgError(PyExc_TypeError, "render_tags: expected a sequence of strings");
            }
            state.renderTags.push_back(PyUnicode_AsUTF8(t));
        }
        Py_DECREF(seq);
    }
    if (clears && clears != Py_None) {
        // {buffer path: a number, or one per channel}
        if (!PyDict_Check(clears)) throw ArgError(PyExc_TypeError, "clear_values: expected a dict of buffer path to numbers");
        PyObject *k, *v;
        Py_ssize_t pos = 0;
        while (PyDict_Next(clears, &pos, &k, &v)) {
            const std::string buffer = ToString(k, "clear_values");
            std::vector<double> values;
            if (PyNumber_Check(v) && !PySequence_Check(v)) {
                const double d = PyFloat_AsDouble(v);
                if (d == -1.0 && PyErr_Occurred()) throw PythonError();
                values.push_back(d);
            } else {
                Numbers n = ReadNumbers(v, 'd');
                values.assign(n.values.begin(), n.values.end());
            }
            bool bound = false;
            for (auto& b : state.aovBindings)
                if (b.renderBufferId == buffer) {
                    b.clearValue = values;
                    bound = true;
                }
            if (!bound) throw ArgError(PyExc_ValueError, "clear_values: '" + buffer + "' is not a bound buffer");
        }
    }
    State& s = S(reinterpret_cast<PyPass*>(self)->owner);
    tide::RenderPass& pass = P(self);
    std::string error;
    bool ok = WithoutGil([&] {
        std::lock_guard<std::mutex> lock(s.mutex);
        for (auto& b : state.aovBindings) b.renderBuffer = s.index->GetRenderBuffer(b.renderBufferId);
        return pass.Execute(state, &error);
    });
    if (!ok) throw std::runtime_error(error);
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Pass_is_converged(PyObject* self, PyObject*) {
    TIDE_TRY
    State& s = S(reinterpret_cast<PyPass*>(self)->owner);
    std::lock_guard<std::mutex> lock(s.mutex);
    return PyBool_FromLong(P(self).IsConverged());
    TIDE_CATCH
}

PyObject* Pass_progress(PyObject* self, PyObject*) {
    TIDE_TRY
    return PyFloat_FromDouble(P(self).GetProgress());
    TIDE_CATCH
}

PyObject* Pass_summary(PyObject* self, PyObject*) {
    TIDE_TRY
    std::vector<std::string> items = P(self).GetSummary();
    PyObject* d = PyDict_New();
    if (!d) return nullptr;
    for (const std::string& kv : items) {
        size_t eq = kv.find('=');
        if (eq == std::string::npos) continue;
        PyObject* v = PyUnicode_FromString(kv.substr(eq + 1).c_str());
        if (!v || PyDict_SetItemString(d, kv.substr(0, eq).c_str(), v) < 0) {
            Py_XDECREF(v);
            Py_DECREF(d);
            return nullptr;
        }
        Py_DECREF(v);
    }
    return d;
    TIDE_CATCH
}

PyObject* Pass_wait(PyObject* self, PyObject* args, PyObject* kw) {
    static const char* names[] = {"timeout_s", nullptr};
    PyObject* timeout = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "|O", const_cast<char**>(names), &timeout)) return nullptr;
    TIDE_TRY
    double t = -1.0;
    if (timeout != Py_None) {
        t = PyFloat_AsDouble(timeout);
        if (t == -1.0 && PyErr_Occurred()) return nullptr;
    }
    tide::RenderPass& pass = P(self);
    bool done = WithoutGil([&] { return pass.Wait(t); });
    std::string error = pass.GetError();
    if (!error.empty()) throw std::runtime_error(error);
    return PyBool_FromLong(done);
    TIDE_CATCH
}

PyObject* Pass_cancel(PyObject* self, PyObject*) {
    TIDE_TRY
    tide::RenderPass& pass = P(self);
    WithoutGil([&] {
        pass.Cancel();
        return 0;
    });
    Py_RETURN_NONE;
    TIDE_CATCH
}

PyObject* Pass_error(PyObject* self, PyObject*) {
    TIDE_TRY
    std::string e = P(self).GetError();
    if (e.empty()) Py_RETURN_NONE;
    return PyUnicode_FromString(e.c_str());
    TIDE_CATCH
}

#define KW(f) reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)(void)>(f)), METH_VARARGS | METH_KEYWORDS

PyMethodDef DelegateMethods[] = {
    {"create_rprim", Delegate_create_rprim, METH_VARARGS, "create_rprim(type, path) -> bool"},
    {"create_sprim", Delegate_create_sprim, METH_VARARGS, "create_sprim(type, path) -> bool"},
    {"create_bprim", Delegate_create_bprim, METH_VARARGS, "create_bprim(type, path) -> bool"},
    {"destroy_prim", Delegate_destroy_prim, METH_VARARGS, "destroy_prim(path) -> bool (False if there was none)"},
    {"set", KW(Delegate_set), "set(path, key, value, time=None); value: bool/int/float/str or ('token'|'asset'|'path'|'string', str) or ('paths', [str])"},
    {"set_array", KW(Delegate_set_array), "set_array(path, key, buffer, tuple_size=1, kind='f', time=None); kind 'f', 'd' or 'i'"},
    {"set_matrix", KW(Delegate_set_matrix), "set_matrix(path, key, matrix (16 numbers or 4x4), time=None)"},
    {"set_primvar", KW(Delegate_set_primvar), "set_primvar(path, name, interpolation, buffer, tuple_size=1, indices=None, kind=None)"},
    {"load_texture", KW(Delegate_load_texture), "load_texture(asset_path) -> True: reads the file once (again when it changes on disk); each material decodes it by its own sourceColorSpace. OSError with the reason when it cannot be read"},
    {"load_vdb", KW(Delegate_load_vdb), "load_vdb(asset_path, field_name, field_index=0) -> bool: reads a volume's grid once per (file, field, index)"},
    {"texture_pixels", Delegate_texture_pixels, METH_VARARGS, "texture_pixels(asset_path) -> (w, h, channels, float32 bytes) as the delegate holds them"},
    {"grid_values", Delegate_grid_values, METH_VARARGS, "grid_values(asset_path, field_name, field_index=0) -> (nx, ny, nz, float32 bytes, x fastest) as the delegate holds them"},
    {"commit_resources", Delegate_commit_resources, METH_NOARGS, "commit_resources() -> [(prim, attribute, message)]"},
    {"check_render", Delegate_check_render, METH_NOARGS, "check_render() -> [(prim, attribute, message)]: commits, then prepares the scene as a render would (the renderer's validation and world build) without rendering"},
    {"last_synced", Delegate_last_synced, METH_NOARGS, "last_synced() -> [path]"},
    {"supported_types", Delegate_supported_types, METH_NOARGS, "supported_types() -> {'rprims': [...], 'sprims': [...], 'bprims': [...]}"},
    {"create_render_pass", Delegate_create_render_pass, METH_NOARGS, "create_render_pass() -> RenderPass"},
    {"pause", Delegate_control<&tide::RenderDelegate::Pause>, METH_NOARGS, "pause() -> bool: holds the render where it is (HdRenderDelegate::Pause)"},
    {"resume", Delegate_control<&tide::RenderDelegate::Resume>, METH_NOARGS, "resume() -> bool: goes on from where it was paused"},
    {"stop", KW(Delegate_stop), "stop(blocking=True) -> bool: ends the render (nothing is published after it returns; blocking, no worker renders either); executions start nothing until restart()"},
    {"restart", Delegate_control<&tide::RenderDelegate::Restart>, METH_NOARGS, "restart() -> bool: renders the last execution asked for, from its start"},
    {"is_paused", Delegate_query<&tide::RenderDelegate::IsPaused>, METH_NOARGS, "is_paused() -> bool"},
    {"is_stopped", Delegate_query<&tide::RenderDelegate::IsStopped>, METH_NOARGS, "is_stopped() -> bool"},
    {"map_buffer", Delegate_map_buffer, METH_VARARGS, "map_buffer(path) -> (w, h, channels, float32 bytes)"},
    {"write_exr", KW(Delegate_write_exr), "write_exr(path, [(name, aov[, dataType])], header: dict)"},
    {"write_preview_png", KW(Delegate_write_preview_png), "write_preview_png(path, buffer_path, color_space='lin_rec709', view='Standard')"},
    {nullptr, nullptr, 0, nullptr}};

PyMethodDef PassMethods[] = {
    {"execute", KW(Pass_execute), "execute(camera_path, [(aov, buffer_path)], settings_path=None, hydra=False, projection=None, clear_values=None, render_tags=None); hydra: Hydra's AOV names and layout (rows from the bottom, depth in clip space, ids in int32 buffers); projection: 16 numbers (GfMatrix4d's order) framing the image; clear_values: {buffer path: a number or one per channel} held until the first pass (Hydra's clearValue); render_tags: the pass's tags (a prim whose renderTag is not among them is not rendered; None or empty: every prim)"},
    {"is_converged", Pass_is_converged, METH_NOARGS, "is_converged() -> bool"},
    {"progress", Pass_progress, METH_NOARGS, "progress() -> float in [0, 1]"},
    {"summary", Pass_summary, METH_NOARGS, "summary() -> {key: value} figures of the last finished pass (photons, memory, ...)"},
    {"wait", KW(Pass_wait), "wait(timeout_s=None) -> bool (True once the pass stopped)"},
    {"cancel", Pass_cancel, METH_NOARGS, "cancel()"},
    {"error", Pass_error, METH_NOARGS, "error() -> str | None"},
    {nullptr, nullptr, 0, nullptr}};

PyMethodDef ModuleMethods[] = {
    {"write_vdb", Module_write_vdb, METH_VARARGS,
     "write_vdb(path, [(name, kind 'float'|'double'|'vec3', (nx, ny, nz), float32 bytes x fastest, voxel_size, "
     "(tx, ty, tz), (ox, oy, oz) index of the first value)]): writes small OpenVDB grids (zeros left inactive)"},
    {nullptr, nullptr, 0, nullptr}};

PyModuleDef ModuleDef = {PyModuleDef_HEAD_INIT, "_tide",
                         "Tide's render delegate (the C++ bridge): create prims, set attributes by USD name, "
                         "commit, render, map buffers, write EXR / preview PNG.",
                         -1, ModuleMethods, nullptr, nullptr, nullptr, nullptr};

}  // namespace

extern "C" PyObject* tide_python_module_init() {
    try {
        PyDelegateType.tp_name = "tide._tide.RenderDelegate";
        PyDelegateType.tp_basicsize = sizeof(PyDelegate);
        PyDelegateType.tp_flags = Py_TPFLAGS_DEFAULT;
        PyDelegateType.tp_doc = "RenderDelegate(): Tide's render delegate.";
        PyDelegateType.tp_new = Delegate_new;
        PyDelegateType.tp_dealloc = Delegate_dealloc;
        PyDelegateType.tp_methods = DelegateMethods;
        if (PyType_Ready(&PyDelegateType) < 0) return nullptr;

        PyPassType.tp_name = "tide._tide.RenderPass";
        PyPassType.tp_basicsize = sizeof(PyPass);
        PyPassType.tp_flags = Py_TPFLAGS_DEFAULT;
        PyPassType.tp_doc = "A progressive render pass (from RenderDelegate.create_render_pass()).";
        PyPassType.tp_dealloc = Pass_dealloc;
        PyPassType.tp_methods = PassMethods;
        if (PyType_Ready(&PyPassType) < 0) return nullptr;

        PyObject* m = PyModule_Create(&ModuleDef);
        if (!m) return nullptr;
        g_error = PyErr_NewException("tide._tide.TideError", PyExc_RuntimeError, nullptr);
        Py_XINCREF(g_error);
        Py_INCREF(&PyDelegateType);
        Py_INCREF(&PyPassType);
        if (!g_error || PyModule_AddObject(m, "TideError", g_error) < 0 ||
            PyModule_AddObject(m, "RenderDelegate", reinterpret_cast<PyObject*>(&PyDelegateType)) < 0 ||
            PyModule_AddObject(m, "RenderPass", reinterpret_cast<PyObject*>(&PyPassType)) < 0) {
            Py_DECREF(m);
            return nullptr;
        }
        return m;
    } catch (const std::exception& e) {
        PyErr_SetString(PyExc_ImportError, e.what());
        return nullptr;
    } catch (...) {
        PyErr_SetString(PyExc_ImportError, "tide._tide: unknown C++ exception during import");
        return nullptr;
    }
}
