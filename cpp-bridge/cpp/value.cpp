//! tide::Value constructors, MemorySceneSource and ChangeTracker.
#include "tide/changeTracker.h"
#include "tide/sceneSource.h"
#include "tide/value.h"

#include <algorithm>
#include <utility>

namespace tide {

const std::string& Value::Text() const {
    static const std::string empty;
    switch (type) {
    case ValueType::Token:
    case ValueType::String:
    case ValueType::Asset:
    case ValueType::Path:
        return s;
    default:
        return empty;
    }
}

const char* Value::TypeName(ValueType t) {
    switch (t) {
    case ValueType::Empty: return "empty";
    case ValueType::Bool: return "bool";
    case ValueType::Int: return "int";
    case ValueType::Float: return "float";
    case ValueType::Token: return "token";
    case ValueType::String: return "string";
    case ValueType::Asset: return "asset";
    case ValueType::Path: return "path";
    case ValueType::Paths: return "paths";
    case ValueType::Floats: return "floats";
    case ValueType::Doubles: return "doubles";
    case ValueType::Ints: return "ints";
    case ValueType::Matrix: return "matrix";
    }
    return "?";
}

static Value Typed(ValueType t) {
    Value v;
    v.type = t;
    return v;
}

Value Value::MakeBool(bool x) { Value v = Typed(ValueType::Bool); v.b = x; return v; }
Value Value::MakeInt(int64_t x) { Value v = Typed(ValueType::Int); v.i = x; return v; }
Value Value::MakeFloat(double x) { Value v = Typed(ValueType::Float); v.f = x; return v; }
Value Value::MakeToken(std::string x) { Value v = Typed(ValueType::Token); v.s = std::move(x); return v; }
Value Value::MakeString(std::string x) { Value v = Typed(ValueType::String); v.s = std::move(x); return v; }
Value Value::MakeAsset(std::string x) { Value v = Typed(ValueType::Asset); v.s = std::move(x); return v; }
Value Value::MakePath(std::string x) { Value v = Typed(ValueType::Path); v.s = std::move(x); return v; }
Value Value::MakePaths(std::vector<std::string> x) { Value v = Typed(ValueType::Paths); v.paths = std::move(x); return v; }
Value Value::MakeFloats(std::vector<float> x, uint32_t tuple) {
    Value v = Typed(ValueType::Floats); v.floats = std::move(x); v.tuple = tuple; return v;
}
Value Value::MakeDoubles(std::vector<double> x, uint32_t tuple) {
    Value v = Typed(ValueType::Doubles); v.doubles = std::move(x); v.tuple = tuple; return v;
}
Value Value::MakeInts(std::vector<int32_t> x) { Value v = Typed(ValueType::Ints); v.ints = std::move(x); return v; }
Value Value::MakeMatrix(const std::array<double, 16>& m) { Value v = Typed(ValueType::Matrix); v.matrix = m; return v; }

// ---------------------------------------------------------------------------------------------
// SceneSource defaults

std::vector<TimedValue> SceneSource::SampleValues(const std::string& path, const std::string& key) const {
    Value v = Get(path, key);
    if (v.IsEmpty()) return {};
    TimedValue tv;
    tv.value = std::move(v);
    return {std::move(tv)};
}

std::vector<std::string> SceneSource::GetPrimvarNames(const std::string&) const { return {}; }

Primvar SceneSource::GetPrimvar(const std::string&, const std::string&) const { return {}; }

// ---------------------------------------------------------------------------------------------
// MemorySceneSource

void MemorySceneSource::Set(const std::string& path, const std::string& key, TimedValue value) {
    std::lock_guard<std::mutex> lock(_mutex);
    auto& samples = _values[path][key];
    if (!value.hasTime) {
        samples.clear();
        samples.push_back(std::move(value));
        return;
    }
    // a value without time gives way to samples (it can only be alone)
    if (!samples.empty() && !samples.front().hasTime) samples.clear();
    // kept sorted by time: found by bisection (samples come in order, so a push)
    auto at = std::lower_bound(samples.begin(), samples.end(), value.time,
                               [](const TimedValue& s, double t) { return s.time < t; });
    if (at != samples.end() && at->time == value.time) {
        *at = std::move(value);
    } else {
        samples.insert(at, std::move(value));
    }
}

void MemorySceneSource::SetPrimvar(const std::string& path, const std::string& name, Primvar primvar) {
    std::lock_guard<std::mutex> lock(_mutex);
    _primvars[path][name] = std::move(primvar);
}

void MemorySceneSource::Remove(const std::string& path) {
    std::lock_guard<std::mutex> lock(_mutex);
    _values.erase(path);
    _primvars.erase(path);
}

Value MemorySceneSource::Get(const std::string& path, const std::string& key) const {
    std::lock_guard<std::mutex> lock(_mutex);
    auto p = _values.find(path);
    if (p == _values.end()) return {};
    auto k = p->second.find(key);
    if (k == p->second.end() || k->second.empty()) return {};
    return k->second.front().value;
}

std::vector<TimedValue> MemorySceneSource::SampleValues(const std::string& path, const std::string& key) const {
    std::lock_guard<std::mutex> lock(_mutex);
    auto p = _values.find(path);
    if (p == _values.end()) return {};
    auto k = p->second.find(key);
    if (k == p->second.end()) return {};
    return k->second;
}

std::vector<std::string> MemorySceneSource::GetKeys(const std::string& path) const {
    std::lock_guard<std::mutex> lock(_mutex);
    std::vector<std::string> keys;
    auto p = _values.find(path);
    if (p != _values.end())
        for (const auto& kv : p->second) keys.push_back(kv.first);
    return keys;
}

std::vector<std::string> MemorySceneSource::GetPrimvarNames(const std::string& path) const {
    std::lock_guard<std::mutex> lock(_mutex);
    std::vector<std::string> names;
    auto p = _primvars.find(path);
    if (p != _primvars.end())
        for (const auto& kv : p->second) names.push_back(kv.first);
    return names;
}

Primvar MemorySceneSource::GetPrimvar(const std::string& path, const std::string& name) const {
    std::lock_guard<std::mutex> lock(_mutex);
    auto p = _primvars.find(path);
    if (p == _primvars.end()) return {};
    auto n = p->second.find(name);
    return n == p->second.end() ? Primvar{} : n->second;
}

// ---------------------------------------------------------------------------------------------
// ChangeTracker

DirtyBits ChangeTracker::BitsForKey(const std::string& typeId, const std::string& key) {
    if (typeId == "renderBuffer") return DirtyDescription;
    if (key == "transform") return DirtyTransform;
    if (key == "visibility" || key == "purpose") return DirtyVisibility;
    if (typeId == "material") return DirtyParams | DirtyResource;
    if (key == "inputs:texture:file" || key == "texture:file") return DirtyParams | DirtyResource;
    if (key == "points") return DirtyPoints;
    if (key == "faceVertexCounts" || key == "faceVertexIndices" || key == "holeIndices" ||
        key == "orientation" || key == "subdivisionScheme" || key == "curveVertexCounts" ||
        key == "interpolateBoundary" || key.rfind("crease", 0) == 0 || key.rfind("corner", 0) == 0 ||
        key == "displayStyle:refineLevel" || key == "faceVaryingLinearInterpolation" ||
        key == "triangleSubdivisionRule" ||
        (typeId == "basisCurves" && (key == "type" || key == "basis" || key == "wrap")))
        return DirtyTopology;
    if (key == "material") return DirtyMaterialId;
    if (key == "instanceTransforms") return DirtyInstancer;
    if (key == "widths" || key == "normals" || key == "velocities" || key == "accelerations")
        return DirtyPrimvar;
    return DirtyParams;
}

void ChangeTracker::MarkDirty(const std::string& path, DirtyBits bits) {
    std::lock_guard<std::mutex> lock(_mutex);
    _bits[path] |= bits;
}

DirtyBits ChangeTracker::GetDirtyBits(const std::string& path) const {
    std::lock_guard<std::mutex> lock(_mutex);
    auto it = _bits.find(path);
    return it == _bits.end() ? Clean : it->second;
}

void ChangeTracker::MarkClean(const std::string& path) {
    std::lock_guard<std::mutex> lock(_mutex);
    auto it = _bits.find(path);
    if (it != _bits.end()) it->second = Clean;
}

void ChangeTracker::Forget(const std::string& path) {
    std::lock_guard<std::mutex> lock(_mutex);
    _bits.erase(path);
}

std::vector<std::string> ChangeTracker::DirtyPaths() const {
    std::lock_guard<std::mutex> lock(_mutex);
    std::vector<std::string> out;
    for (const auto& kv : _bits)
        if (kv.second != Clean) out.push_back(kv.first);
    return out;
}

}  // namespace tide
