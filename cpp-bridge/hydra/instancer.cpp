//! HdTideInstancer (see instancer.h).
#include "instancer.h"
#include "hdTide.h"

#include "pxr/base/gf/matrix4f.h"
#include "pxr/base/gf/quatd.h"
#include "pxr/base/gf/quatf.h"
#include "pxr/base/gf/quath.h"
#include "pxr/base/gf/vec3d.h"
#include "pxr/base/gf/vec3f.h"
#include "pxr/base/gf/vec3h.h"
#include "pxr/base/gf/vec4d.h"
#include "pxr/base/gf/vec4f.h"
#include "pxr/imaging/hd/changeTracker.h"
#include "pxr/imaging/hd/renderIndex.h"
#include "pxr/imaging/hd/sceneDelegate.h"
#include "pxr/imaging/hd/tokens.h"

#include <algorithm>

PXR_NAMESPACE_OPEN_SCOPE

namespace {

/// A vec3 primvar (float, double or half) as doubles; false for another type.
bool Vec3s(VtValue const& v, std::vector<GfVec3d>* out) {
    auto copy = [out](auto const& a) {
        out->assign(a.begin(), a.end());
        return true;
    };
    if (v.IsHolding<VtVec3fArray>()) return copy(v.UncheckedGet<VtVec3fArray>());
    if (v.IsHolding<VtVec3dArray>()) return copy(v.UncheckedGet<VtVec3dArray>());
    if (v.IsHolding<VtVec3hArray>()) return copy(v.UncheckedGet<VtVec3hArray>());
    return false;
}

/// A rotation primvar: quaternions (half, float, double) or vec4s read as (real, i, j, k).
bool Quats(VtValue const& v, std::vector<GfQuatd>* out) {
    auto quats = [out](auto const& a) {
        for (auto const& q : a) out->push_back(GfQuatd(q.GetReal(), GfVec3d(q.GetImaginary())));
        return true;
    };
    auto vec4s = [out](auto const& a) {
        for (auto const& x : a) out->push_back(GfQuatd(x[0], x[1], x[2], x[3]));
        return true;
    };
    out->clear();
    if (v.IsHolding<VtQuathArray>()) return quats(v.UncheckedGet<VtQuathArray>());
    if (v.IsHolding<VtQuatfArray>()) return quats(v.UncheckedGet<VtQuatfArray>());
    if (v.IsHolding<VtQuatdArray>()) return quats(v.UncheckedGet<VtQuatdArray>());
    if (v.IsHolding<VtVec4fArray>()) return vec4s(v.UncheckedGet<VtVec4fArray>());
    if (v.IsHolding<VtVec4dArray>()) return vec4s(v.UncheckedGet<VtVec4dArray>());
    return false;
}

bool Matrices(VtValue const& v, std::vector<GfMatrix4d>* out) {
    if (v.IsHolding<VtMatrix4dArray>()) {
        auto const& a = v.UncheckedGet<VtMatrix4dArray>();
        out->assign(a.begin(), a.end());
        return true;
    }
    if (v.IsHolding<VtMatrix4fArray>()) {
        out->clear();
        for (GfMatrix4f const& m : v.UncheckedGet<VtMatrix4fArray>()) out->push_back(GfMatrix4d(m));
        return true;
    }
    return false;
}

/// The value of `s` at `time` (linear between neighbours, held beyond the ends), or Empty.
VtValue At(HdTimeSampleArray<VtValue, 4> const& s, float time) {
    if (s.count == 0) return VtValue();
    if (s.count == 1) return s.values[0];
    return s.Resample(time);
}

void AddTimes(HdTimeSampleArray<VtValue, 4> const& s, std::vector<float>* times) {
    times->insert(times->end(), s.times.begin(), s.times.begin() + s.count);
}

}  // namespace

HdTideInstancer::HdTideInstancer(HdSceneDelegate* delegate, SdfPath const& id) : HdInstancer(delegate, id) {}

void HdTideInstancer::Sync(HdSceneDelegate* sd, HdRenderParam*, HdDirtyBits* dirtyBits) {
    // _SyncInstancerAndParents also calls Sync, with clean bits, for the rprims that waited on
    // the instancer's lock while another one synced it; those may already be reading it
    if (*dirtyBits == HdChangeTracker::Clean) return;
    _UpdateInstancer(sd, dirtyBits);
    SdfPath const& id = GetId();
    // over the plugin's sampling window (scene indices give one sample without one)
    const float t0 = HdTideSampleOpen(), t1 = HdTideSampleClose();
    sd->SampleInstancerTransform(id, t0, t1, &_xform);
    sd->SamplePrimvar(id, HdInstancerTokens->instanceTranslations, t0, t1, &_translations);
    sd->SamplePrimvar(id, HdInstancerTokens->instanceRotations, t0, t1, &_rotations);
    sd->SamplePrimvar(id, HdInstancerTokens->instanceScales, t0, t1, &_scales);
    sd->SamplePrimvar(id, HdInstancerTokens->instanceTransforms, t0, t1, &_matrices);
}

void HdTideInstancer::_Times(std::vector<float>* times) const {
    times->insert(times->end(), _xform.times.begin(), _xform.times.begin() + _xform.count);
    for (auto const* s : {&_translations, &_rotations, &_scales, &_matrices}) AddTimes(*s, times);
    if (GetParentId().IsEmpty()) return;
    if (auto const* parent = dynamic_cast<HdTideInstancer const*>(GetDelegate()->GetRenderIndex().GetInstancer(GetParentId())))
        parent->_Times(times);
}

VtMatrix4dArray HdTideInstancer::_TransformsAt(SdfPath const& prototypeId, float time) {
    const VtIntArray indices = GetDelegate()->GetInstanceIndices(GetId(), prototypeId);
    const GfMatrix4d instancer = _xform.count == 0 ? GfMatrix4d(1.0)
                                 : _xform.count == 1 ? _xform.values[0]
                                                     : _xform.Resample(time);
    std::vector<GfVec3d> translations, scales;
    std::vector<GfQuatd> rotations;
    std::vector<GfMatrix4d> matrices;
    Vec3s(At(_translations, time), &translations);
    Vec3s(At(_scales, time), &scales);
    Quats(At(_rotations, time), &rotations);
    Matrices(At(_matrices, time), &matrices);

    VtMatrix4dArray level(indices.size());
    for (size_t i = 0; i < indices.size(); ++i) {
        // an index past a primvar's end leaves that part of the placement out (identity)
        const size_t k = size_t(std::max(indices[i], 0));
        GfMatrix4d m(1.0);
        if (k < matrices.size()) m = matrices[k];
        if (k < scales.size()) m *= GfMatrix4d(1.0).SetScale(scales[k]);
        if (k < rotations.size()) m *= GfMatrix4d(1.0).SetRotate(rotations[k].GetNormalized());
        if (k < translations.size()) m *= GfMatrix4d(1.0).SetTranslate(translations[k]);
        level[i] = m * instancer;
    }
    if (GetParentId().IsEmpty()) return level;
    auto* parent = dynamic_cast<HdTideInstancer*>(GetDelegate()->GetRenderIndex().GetInstancer(GetParentId()));
    if (!parent) return level;
    const VtMatrix4dArray outer = parent->_TransformsAt(GetId(), time);
    VtMatrix4dArray flat(outer.size() * level.size());
    for (size_t i = 0; i < outer.size(); ++i)
        for (size_t j = 0; j < level.size(); ++j) flat[i * level.size() + j] = level[j] * outer[i];
    return flat;
}

HdTideInstanceSamples HdTideInstancer::SampleInstanceTransforms(SdfPath const& prototypeId) {
    std::vector<float> times;
    _Times(&times);
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    if (times.empty()) times.push_back(0.0f);

    HdTideInstanceSamples out;
    for (float t : times) {
        out.times.push_back(t);
        out.transforms.push_back(_TransformsAt(prototypeId, t));
    }
    // Hydra returns the shutter's ends even for still values: one sample when nothing moves
    const bool still = std::all_of(out.transforms.begin(), out.transforms.end(),
                                   [&](VtMatrix4dArray const& a) { return a == out.transforms.front(); });
    if (still) {
        out.times = {0.0f};
        out.transforms.resize(1);
    }
    return out;
}

std::vector<std::pair<std::string, tide::Primvar>> HdTideInstancer::InstancePrimvars(SdfPath const& prototypeId) {
    std::vector<std::pair<std::string, tide::Primvar>> out;
    HdSceneDelegate* sd = GetDelegate();
    VtIntArray const indices = sd->GetInstanceIndices(GetId(), prototypeId);
    size_t parents = 1;
    if (!GetParentId().IsEmpty())
        if (auto* parent = dynamic_cast<HdTideInstancer*>(sd->GetRenderIndex().GetInstancer(GetParentId())))
            parents = parent->_TransformsAt(GetId(), 0.0f).size();
    static const TfToken placement[] = {HdInstancerTokens->instanceTranslations, HdInstancerTokens->instanceRotations,
                                        HdInstancerTokens->instanceScales, HdInstancerTokens->instanceTransforms};
    for (HdPrimvarDescriptor const& d : sd->GetPrimvarDescriptors(GetId(), HdInterpolationInstance)) {
        if (std::find(std::begin(placement), std::end(placement), d.name) != std::end(placement)) continue;
        VtIntArray valueIndices;
        tide::Value v = HdTideToValue(d.indexed ? sd->GetIndexedPrimvar(GetId(), d.name, &valueIndices) : sd->Get(GetId(), d.name));
        std::vector<float> values;
        uint32_t tuple = 1;
        if (v.type == tide::ValueType::Floats) {
            values = v.floats;
            tuple = v.tuple;
        } else if (v.type == tide::ValueType::Doubles) {
            values.assign(v.doubles.begin(), v.doubles.end());
            tuple = v.tuple;
        } else if (v.type == tide::ValueType::Ints) {
            values.assign(v.ints.begin(), v.ints.end());
        } else {
            continue;
        }
        if (tuple == 0 || tuple > 4) continue;
        const size_t n = values.size() / tuple;
        std::vector<float> rows;
        rows.reserve(parents * indices.size() * tuple);
        bool ok = true;
        for (size_t p = 0; p < parents && ok; ++p)
            for (int i : indices) {
                size_t k = size_t(std::max(i, 0));
                if (d.indexed) k = k < valueIndices.size() ? size_t(std::max(valueIndices[k], 0)) : n;
                if (k >= n) {
                    ok = false;
                    break;
                }
                rows.insert(rows.end(), values.begin() + k * tuple, values.begin() + (k + 1) * tuple);
            }
        if (!ok) continue;
        tide::Primvar pv;
        pv.interpolation = "instance";
        pv.data = tide::Value::MakeFloats(std::move(rows), tuple);
        out.emplace_back(d.name.GetString(), std::move(pv));
    }
    // the parent level's, for names this level lacks: each parent instance's row over the
    // instances it places (the order of _TransformsAt: parent-major)
    if (!GetParentId().IsEmpty())
        if (auto* parent = dynamic_cast<HdTideInstancer*>(sd->GetRenderIndex().GetInstancer(GetParentId())))
            for (auto& [name, pv] : parent->InstancePrimvars(GetId())) {
                if (std::any_of(out.begin(), out.end(), [&](auto const& e) { return e.first == name; })) continue;
                const uint32_t tuple = pv.data.tuple;
                std::vector<float> const& outer = pv.data.floats;
                std::vector<float> rows;
                rows.reserve(outer.size() * indices.size());
                for (size_t p = 0; p + tuple <= outer.size(); p += tuple)
                    for (size_t k = 0; k < indices.size(); ++k) rows.insert(rows.end(), outer.begin() + p, outer.begin() + p + tuple);
                pv.data = tide::Value::MakeFloats(std::move(rows), tuple);
                out.emplace_back(name, std::move(pv));
            }
    return out;
}

std::vector<std::set<TfToken>> HdTideInstancer::InstanceCategories(SdfPath const& prototypeId) {
    HdSceneDelegate* sd = GetDelegate();
    VtIntArray const indices = sd->GetInstanceIndices(GetId(), prototypeId);
    std::vector<VtArray<TfToken>> const all = sd->GetInstanceCategories(GetId());
    std::vector<std::set<TfToken>> level(indices.size());
    for (size_t i = 0; i < indices.size(); ++i) {
        const size_t k = size_t(std::max(indices[i], 0));
        if (k < all.size()) level[i].insert(all[k].begin(), all[k].end());
    }
    if (GetParentId().IsEmpty()) return level;
    auto* parent = dynamic_cast<HdTideInstancer*>(sd->GetRenderIndex().GetInstancer(GetParentId()));
    if (!parent) return level;
    // parent-major, as _TransformsAt flattens
    std::vector<std::set<TfToken>> const outer = parent->InstanceCategories(GetId());
    std::vector<std::set<TfToken>> flat;
    flat.reserve(outer.size() * level.size());
    for (auto const& o : outer)
        for (auto const& l : level) {
            flat.push_back(l);
            flat.back().insert(o.begin(), o.end());
        }
    return flat;
}

PXR_NAMESPACE_CLOSE_SCOPE
