//! RenderParam (forwarding values to Rust), the prims' Sync, and RenderBuffer.
#include "tide/prims.h"
#include "tide/renderBuffer.h"
#include "tide/renderParam.h"
#include "tide/texture.h"

#include <exception>
#include <utility>

namespace tide {

namespace {

rust::Str Str(const std::string& s) { return rust::Str(s.data(), s.size()); }

template <typename T>
rust::Slice<const T> SliceOf(const std::vector<T>& v) {
    return rust::Slice<const T>(v.data(), v.size());
}

bool EndsWith(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// RenderParam

RenderParam::RenderParam() : _delegate(rs::new_delegate()), _textures(new TextureCache()) {}

RenderParam::~RenderParam() = default;

void RenderParam::AddBuffer(const std::string& id, RenderBuffer* buffer) {
    std::lock_guard<std::mutex> lock(_buffersMutex);
    _buffers[id] = buffer;
}

void RenderParam::RemoveBuffer(const std::string& id, const RenderBuffer* buffer) {
    std::lock_guard<std::mutex> lock(_buffersMutex);
    auto it = _buffers.find(id);
    // a buffer made again under the same id before the old one went keeps its entry
    if (it != _buffers.end() && it->second == buffer) _buffers.erase(it);
}

void RenderParam::SetBuffersConverged(const std::vector<std::string>& ids, bool converged) {
    std::lock_guard<std::mutex> lock(_buffersMutex);
    for (const auto& id : ids) {
        auto it = _buffers.find(id);
        if (it != _buffers.end()) it->second->SetConverged(converged);
    }
}

bool RenderParam::Forward(const std::string& path, const std::string& key, const TimedValue& tv) {
    const Value& v = tv.value;
    const bool t = tv.hasTime;
    const double time = tv.time;
    try {
        switch (v.type) {
        case ValueType::Empty: return true;
        case ValueType::Bool: _delegate->set_bool(Str(path), Str(key), v.b, t, time); break;
        case ValueType::Int: _delegate->set_int(Str(path), Str(key), v.i, t, time); break;
        case ValueType::Float: _delegate->set_float(Str(path), Str(key), v.f, t, time); break;
        case ValueType::Token: _delegate->set_text(Str(path), Str(key), 0, Str(v.s), t, time); break;
        case ValueType::String: _delegate->set_text(Str(path), Str(key), 1, Str(v.s), t, time); break;
        case ValueType::Asset: _delegate->set_text(Str(path), Str(key), 2, Str(v.s), t, time); break;
        case ValueType::Path: _delegate->set_text(Str(path), Str(key), 3, Str(v.s), t, time); break;
        case ValueType::Paths: {
            rust::Vec<rust::String> paths;
            paths.reserve(v.paths.size());
            for (const auto& p : v.paths) paths.push_back(rust::String(p));
            _delegate->set_paths(Str(path), Str(key), paths, t, time);
            break;
        }
        case ValueType::Floats: _delegate->set_floats(Str(path), Str(key), SliceOf(v.floats), v.tuple, t, time); break;
        case ValueType::Doubles: _delegate->set_doubles(Str(path), Str(key), SliceOf(v.doubles), v.tuple, t, time); break;
        case ValueType::Ints: _delegate->set_ints(Str(path), Str(key), SliceOf(v.ints), t, time); break;
        case ValueType::Matrix:
            _delegate->set_matrix(Str(path), Str(key), rust::Slice<const double>(v.matrix.data(), 16), t, time);
            break;
        }
        return true;
    } catch (const std::exception& e) {
        AddProblem(path, key, e.what());
        return false;
    }
}

bool RenderParam::ForwardPrimvar(const std::string& path, const std::string& name, const Primvar& pv) {
    const std::vector<float> none;
    const std::vector<int32_t> noInts;
    std::vector<float> converted;
    const std::vector<float>* floats = &none;
    const std::vector<int32_t>* ints = &noInts;
    uint8_t kind = 'f';
    switch (pv.data.type) {
    case ValueType::Floats: floats = &pv.data.floats; break;
    case ValueType::Doubles:
        converted.assign(pv.data.doubles.begin(), pv.data.doubles.end());
        floats = &converted;
        break;
    case ValueType::Ints:
        kind = 'i';
        ints = &pv.data.ints;
        break;
    case ValueType::Empty: return true;
    default:
        AddProblem(path, "primvars:" + name,
                   std::string("a primvar holds floats, doubles or ints, not ") + Value::TypeName(pv.data.type));
        return false;
    }
    try {
        _delegate->set_primvar(Str(path), Str(name), Str(pv.interpolation), kind, SliceOf(*floats), SliceOf(*ints),
                               pv.data.tuple, pv.indexed, SliceOf(pv.indices));
        return true;
    } catch (const std::exception& e) {
        AddProblem(path, "primvars:" + name, e.what());
        return false;
    }
}

void RenderParam::AddProblem(const std::string& prim, const std::string& attribute, const std::string& message) {
    std::lock_guard<std::mutex> lock(_problemsMutex);
    _problems.push_back(Problem{prim, attribute, message});
}

std::vector<Problem> RenderParam::TakeProblems() {
    std::lock_guard<std::mutex> lock(_problemsMutex);
    return std::exchange(_problems, {});
}

void RenderParam::NoteSynced(const std::string& path) {
    std::lock_guard<std::mutex> lock(_problemsMutex);
    _synced.insert(path);
}

std::set<std::string> RenderParam::TakeSynced() {
    std::lock_guard<std::mutex> lock(_problemsMutex);
    return std::exchange(_synced, {});
}

// ---------------------------------------------------------------------------------------------
// Prims

Prim::Prim(const std::string& id, const std::string& typeId, RenderParam* param)
    : _id(id), _typeId(typeId), _param(param) {}

Prim::~Prim() = default;

void Prim::Sync(SceneSource& source, DirtyBits* dirtyBits) {
    if (!dirtyBits || *dirtyBits == ChangeTracker::Clean) return;
    _param->NoteSynced(_id);
    _SyncKeys(source, *dirtyBits);
    if (*dirtyBits & ChangeTracker::DirtyPrimvar) _SyncPrimvars(source);
    *dirtyBits = ChangeTracker::Clean;
}

void Prim::_SyncKeys(SceneSource& source, DirtyBits bits) {
    for (const std::string& key : source.GetKeys(_id)) {
        if (!(ChangeTracker::BitsForKey(_typeId, key) & bits)) continue;
        for (const TimedValue& tv : source.SampleValues(_id, key)) _param->Forward(_id, key, tv);
    }
}

void Prim::_SyncPrimvars(SceneSource& source) {
    for (const std::string& name : source.GetPrimvarNames(_id))
        _param->ForwardPrimvar(_id, name, source.GetPrimvar(_id, name));
}

void Prim::Finalize() {
    if (_finalized) return;
    _finalized = true;
    try {
        _param->GetDelegate().destroy_prim(Str(_id));
    } catch (const std::exception& e) {
        _param->AddProblem(_id, "", e.what());
    }
}

bool SendTexture(RenderParam& param, const std::string& asset, std::string* error) {
    TextureCache& cache = param.GetTextureCache();
    if (cache.AlreadySent(asset)) return true;
    bool ok = false;
    try {
        TextureImage image;
        ok = cache.Read(asset, &image, error);
        const auto w = uint32_t(image.width), h = uint32_t(image.height), c = uint32_t(image.channels);
        if (ok) {
            param.GetDelegate().add_texels(Str(asset), w, h, c, std::move(*image.texels), image.isSrgb,
                                           Str(image.wrapmodes));
        } else {
            param.GetDelegate().texture_failed(Str(asset), Str(*error));
        }
    } catch (const std::exception& e) {
        ok = false;
        *error = e.what();
    }
    if (!ok) cache.ForgetSent(asset);
    return ok;
}

bool LoadTextureFor(RenderParam& param, const std::string& prim, const std::string& attribute,
                    const std::string& asset) {
    std::string error;
    if (SendTexture(param, asset, &error)) return true;
    param.AddProblem(prim, attribute, "cannot read texture '" + asset + "': " + error + " (the input falls back)");
    return false;
}

void Material::Sync(SceneSource& source, DirtyBits* dirtyBits) {
    // as a light's: any sync picks up texture files rewritten on disk
    if (dirtyBits && *dirtyBits) {
        for (const std::string& key : source.GetKeys(_id)) {
            if (!EndsWith(key, ".inputs:file") && !EndsWith(key, ".file")) continue;
            Value v = source.Get(_id, key);
            if (v.type != ValueType::Asset || v.s.empty()) continue;
            LoadTextureFor(*_param, _id, key, v.s);
        }
    }
    Prim::Sync(source, dirtyBits);
}

void Light::Sync(SceneSource& source, DirtyBits* dirtyBits) {
    // on any sync, not only a resource change: an edit to the light (its intensity, say) also
    // picks up its texture file rewritten on disk (an unchanged file costs a stat)
    if (dirtyBits && *dirtyBits) {
        for (const char* key : {"inputs:texture:file", "texture:file"}) {
            Value v = source.Get(_id, key);
            if (v.type == ValueType::Asset && !v.s.empty()) LoadTextureFor(*_param, _id, key, v.s);
        }
    }
    Prim::Sync(source, dirtyBits);
}

// ---------------------------------------------------------------------------------------------
// RenderBuffer

int FormatComponents(Format f) {
    switch (f) {
    case Format::Float32: return 1;
    case Format::Float32Vec2: return 2;
    case Format::Float32Vec3: return 3;
    case Format::Float32Vec4: return 4;
    case Format::Int32: return 1;
    case Format::Invalid: return 0;
    }
    return 0;
}

Format FormatFromName(const std::string& name) {
    std::string n = name;
    if (n.rfind("HdFormat", 0) == 0) n = n.substr(8);
    if (n == "float" || n == "Float32" || n == "float32") return Format::Float32;
    if (n == "float2" || n == "Float32Vec2" || n == "color2f") return Format::Float32Vec2;
    if (n == "float3" || n == "Float32Vec3" || n == "color3f") return Format::Float32Vec3;
    if (n == "float4" || n == "Float32Vec4" || n == "color4f") return Format::Float32Vec4;
    if (n == "int" || n == "Int32" || n == "int32") return Format::Int32;
    return Format::Invalid;
}

static const char* FormatName(Format f) {
    switch (f) {
    case Format::Float32: return "float";
    case Format::Float32Vec2: return "float2";
    case Format::Float32Vec3: return "float3";
    case Format::Float32Vec4: return "float4";
    case Format::Int32: return "int32";
    case Format::Invalid: return "invalid";
    }
    return "invalid";
}

RenderBuffer::RenderBuffer(const std::string& id, RenderParam* param) : Bprim(id, "renderBuffer", param) {
    if (_param) _param->AddBuffer(_id, this);
}

RenderBuffer::~RenderBuffer() {
    if (_param) _param->RemoveBuffer(_id, this);
}

void RenderBuffer::Sync(SceneSource& source, DirtyBits* dirtyBits) {
    if (!dirtyBits || *dirtyBits == ChangeTracker::Clean) return;
    Value dims = source.Get(_id, "dimensions");
    Value format = source.Get(_id, "format");
    Format f = Format::Float32Vec4;
    if (!format.Text().empty()) {
        f = FormatFromName(format.Text());
        if (f == Format::Invalid) {
            _param->AddProblem(_id, "format", "unknown format '" + format.Text() + "' (float4 used)");
            f = Format::Float32Vec4;
        }
    }
    for (const std::string& key : source.GetKeys(_id)) {
        if (key == "dimensions" || key == "format") continue;
        for (const TimedValue& tv : source.SampleValues(_id, key)) _param->Forward(_id, key, tv);
    }
    if (dims.type == ValueType::Ints && dims.ints.size() >= 2) {
        Allocate(dims.ints[0], dims.ints[1], dims.ints.size() > 2 ? dims.ints[2] : 1, f);
    } else if (!dims.IsEmpty()) {
        _param->AddProblem(_id, "dimensions", "expected two ints (width, height)");
    }
    *dirtyBits = ChangeTracker::Clean;
}

bool RenderBuffer::Allocate(int width, int height, int depth, Format format, bool multiSampled) {
    (void)multiSampled;
    if (width <= 0 || height <= 0 || depth != 1 || width > (1 << 16) || height > (1 << 16)) {
        _param->AddProblem(_id, "dimensions",
                           "unusable size " + std::to_string(width) + "x" + std::to_string(height) + "x" +
                               std::to_string(depth) + " (want positive width and height up to 65536, depth 1)");
        return false;
    }
    if (format == Format::Invalid) {
        _param->AddProblem(_id, "format", "invalid format");
        return false;
    }
    TimedValue dims;
    dims.value = Value::MakeInts({width, height});
    TimedValue fmt;
    fmt.value = Value::MakeToken(FormatName(format));
    if (!_param->Forward(_id, "dimensions", dims) || !_param->Forward(_id, "format", fmt)) return false;
    _width = unsigned(width);
    _height = unsigned(height);
    _format = format;
    _channels = FormatComponents(format);
    // the storage is taken when the buffer is first mapped or resolved: a buffer nobody reads
    // (an AOV that only goes to a file) holds no pixels
    std::vector<float>().swap(_pixels);
    _converged.store(false);
    return true;
}

void* RenderBuffer::Map() {
    if (_mappers.load() == 0 && _pixels.size() != size_t(_width) * _height * size_t(_channels)) {
        // mapped before any Resolve: the delegate's pixels (its clear value before a pass)
        Resolve();
        const size_t n = size_t(_width) * _height * size_t(_channels);
        if (_pixels.size() != n) _pixels.assign(n, 0.0f);
    }
    _mappers++;
    return _pixels.data();
}

void RenderBuffer::Unmap() { _mappers--; }

void RenderBuffer::Resolve() {
    if (IsMapped()) return;
    try {
        // the delegate's pixels are copied straight into this buffer's storage, with no copy
        // in between; a pass publishing another size between the two calls is read again
        auto& delegate = _param->GetDelegate();
        for (int attempt = 0; attempt < 4; ++attempt) {
            rs::MappedBuffer shape = delegate.buffer_shape(Str(_id));
            const size_t n = size_t(shape.width) * shape.height * size_t(shape.channels);
            if (n == 0) return;
            if (_pixels.size() != n) {
                std::vector<float>().swap(_pixels);
                _pixels.resize(n);
            }
            if (delegate.read_buffer(Str(_id), rust::Slice<float>(_pixels.data(), n))) {
                _width = shape.width;
                _height = shape.height;
                _channels = int(shape.channels);
                return;
            }
        }
        _param->AddProblem(_id, "", "the buffer kept changing size while it was read");
    } catch (const std::exception& e) {
        _param->AddProblem(_id, "", e.what());
    }
}

}  // namespace tide
