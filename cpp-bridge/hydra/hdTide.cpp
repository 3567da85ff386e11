//! hdTide: the Hd* classes over tide:: (see hdTide.h).
#include "hdTide.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "tide/renderParam.h"
#include "tide/vdb.h"

#include "pxr/base/gf/camera.h"
#include "pxr/base/gf/matrix4d.h"
#include "pxr/base/gf/range1d.h"
#include "pxr/base/gf/range1f.h"
#include "pxr/base/gf/range2f.h"
#include "pxr/base/gf/vec2f.h"
#include "pxr/base/gf/vec2i.h"
#include "pxr/base/gf/vec3f.h"
#include "pxr/base/gf/vec4f.h"
#include "pxr/imaging/hd/camera.h"
#include "pxr/imaging/hd/field.h"
#include "pxr/imaging/hd/geomSubset.h"
#include "pxr/imaging/hd/instancer.h"
#include "pxr/imaging/hd/light.h"
#include "pxr/imaging/hd/material.h"
#include "pxr/imaging/hd/meshTopology.h"
#include "pxr/imaging/hd/renderIndex.h"
#include "pxr/imaging/hd/renderPassState.h"
#include "pxr/imaging/hd/renderSettings.h"
#include "pxr/imaging/hd/resourceRegistry.h"
#include "pxr/imaging/hd/sceneDelegate.h"
#include "pxr/imaging/hd/sceneIndex.h"
#include "pxr/imaging/hd/tokens.h"
#include "pxr/imaging/hd/volume.h"
#include "pxr/usd/sdf/assetPath.h"

#include <type_traits>

PXR_NAMESPACE_OPEN_SCOPE

namespace {

template <typename T, size_t N>
tide::Value FloatTuples(VtArray<T> const& a) {
    std::vector<float> f;
    f.reserve(a.size() * N);
    for (auto const& x : a)
        for (size_t i = 0; i < N; ++i) f.push_back(float(x[i]));
    return tide::Value::MakeFloats(std::move(f), N);
}

}  // namespace

tide::Value HdTideToValue(VtValue const& v) {
    using tide::Value;
    if (v.IsHolding<bool>()) return Value::MakeBool(v.UncheckedGet<bool>());
    if (v.IsHolding<int>()) return Value::MakeInt(v.UncheckedGet<int>());
    if (v.IsHolding<int64_t>()) return Value::MakeInt(v.UncheckedGet<int64_t>());
    if (v.IsHolding<unsigned int>()) return Value::MakeInt(v.UncheckedGet<unsigned int>());
    if (v.IsHolding<float>()) return Value::MakeFloat(v.UncheckedGet<float>());
    if (v.IsHolding<double>()) return Value::MakeFloat(v.UncheckedGet<double>());
    if (v.IsHolding<TfToken>()) return Value::MakeToken(v.UncheckedGet<TfToken>().GetString());
    if (v.IsHolding<std::string>()) return Value::MakeString(v.UncheckedGet<std::string>());
    if (v.IsHolding<SdfAssetPath>()) {
        SdfAssetPath const& a = v.UncheckedGet<SdfAssetPath>();
        return Value::MakeAsset(a.GetResolvedPath().empty() ? a.GetAssetPath() : a.GetResolvedPath());
    }
    if (v.IsHolding<SdfPath>()) return Value::MakePath(v.UncheckedGet<SdfPath>().GetString());
    if (v.IsHolding<VtTokenArray>()) {
        std::vector<std::string> p;
        for (TfToken const& t : v.UncheckedGet<VtTokenArray>()) p.push_back(t.GetString());
        return Value::MakePaths(std::move(p));
    }
    if (v.IsHolding<SdfPathVector>()) {
        std::vector<std::string> p;
        for (auto const& x : v.UncheckedGet<SdfPathVector>()) p.push_back(x.GetString());
        return Value::MakePaths(std::move(p));
    }
    if (v.IsHolding<GfMatrix4d>()) {
        std::array<double, 16> m{};
        const double* d = v.UncheckedGet<GfMatrix4d>().GetArray();
        std::copy(d, d + 16, m.begin());
        return Value::MakeMatrix(m);
    }
    if (v.IsHolding<GfVec2f>()) { auto x = v.UncheckedGet<GfVec2f>(); return Value::MakeFloats({x[0], x[1]}, 2); }
    if (v.IsHolding<GfVec3f>()) { auto x = v.UncheckedGet<GfVec3f>(); return Value::MakeFloats({x[0], x[1], x[2]}, 3); }
    if (v.IsHolding<GfVec4f>()) { auto x = v.UncheckedGet<GfVec4f>(); return Value::MakeFloats({x[0], x[1], x[2], x[3]}, 4); }
    if (v.IsHolding<GfRange1f>()) {
        auto r = v.UncheckedGet<GfRange1f>();
        return Value::MakeFloats({r.GetMin(), r.GetMax()}, 2);
    }
    if (v.IsHolding<GfRange1d>()) {
        auto r = v.UncheckedGet<GfRange1d>();
        return Value::MakeFloats({float(r.GetMin()), float(r.GetMax())}, 2);
    }
    if (v.IsHolding<GfVec2i>()) { auto x = v.UncheckedGet<GfVec2i>(); return Value::MakeInts({x[0], x[1]}); }
    if (v.IsHolding<VtFloatArray>()) {
        auto const& a = v.UncheckedGet<VtFloatArray>();
        return Value::MakeFloats(std::vector<float>(a.begin(), a.end()), 1);
    }
    if (v.IsHolding<VtDoubleArray>()) {
        auto const& a = v.UncheckedGet<VtDoubleArray>();
        return Value::MakeDoubles(std::vector<double>(a.begin(), a.end()), 1);
    }
    if (v.IsHolding<VtIntArray>()) {
        auto const& a = v.UncheckedGet<VtIntArray>();
        return Value::MakeInts(std::vector<int32_t>(a.begin(), a.end()));
    }
    if (v.IsHolding<VtVec2fArray>()) return FloatTuples<GfVec2f, 2>(v.UncheckedGet<VtVec2fArray>());
    if (v.IsHolding<VtVec3fArray>()) return FloatTuples<GfVec3f, 3>(v.UncheckedGet<VtVec3fArray>());
    if (v.IsHolding<VtVec4fArray>()) return FloatTuples<GfVec4f, 4>(v.UncheckedGet<VtVec4fArray>());
    if (v.IsHolding<std::vector<GfVec4d>>()) {  // HdCamera's clipPlanes
        std::vector<float> f;
        for (auto const& p : v.UncheckedGet<std::vector<GfVec4d>>())
            for (int k = 0; k < 4; ++k) f.push_back(float(p[k]));
        return Value::MakeFloats(std::move(f), 4);
    }
    if (v.IsHolding<VtMatrix4dArray>()) {
        std::vector<double> d;
        for (auto const& m : v.UncheckedGet<VtMatrix4dArray>()) d.insert(d.end(), m.GetArray(), m.GetArray() + 16);
        return Value::MakeDoubles(std::move(d), 16);
    }
    return {};
}

// ---------------------------------------------------------------------------------------------
// Motion sampling window

namespace {
std::atomic<float> g_sampleOpen{-1.0f};
std::atomic<float> g_sampleClose{1.0f};

/// Widens the sampling window to a camera's shutter.
void WidenSampling(VtValue const& open, VtValue const& close) {
    auto widen = [](std::atomic<float>& a, double v, bool lower) {
        float cur = a.load();
        const float f = float(v);
        while ((lower ? f < cur : f > cur) && !a.compare_exchange_weak(cur, f)) {
        }
    };
    if (open.IsHolding<double>() && std::isfinite(open.UncheckedGet<double>())) widen(g_sampleOpen, open.UncheckedGet<double>(), true);
    if (close.IsHolding<double>() && std::isfinite(close.UncheckedGet<double>())) widen(g_sampleClose, close.UncheckedGet<double>(), false);
}
}  // namespace

float HdTideSampleOpen() { return g_sampleOpen.load(); }
float HdTideSampleClose() { return g_sampleClose.load(); }

// ---------------------------------------------------------------------------------------------
// HdTideSnapshot

namespace {

/// An Hd parameter read under Tide's key (the USD attribute name the reader sends), divided by
/// `unit` when Hydra hands it in other units (camera apertures and focal length in scene units).
struct Param {
    TfToken hd;
    std::string key;
    double unit = 1.0;
};

// Lights: HdLightTokens, which UsdImaging maps to the UsdLux inputs; the other names fall back
// to the prim's attribute of that name.
const std::vector<Param>& LightParams() {
    static const std::vector<Param> p = {
        {HdLightTokens->intensity, "inputs:intensity"},
        {HdLightTokens->exposure, "inputs:exposure"},
        {HdLightTokens->color, "inputs:color"},
        {HdLightTokens->normalize, "inputs:normalize"},
        {HdLightTokens->enableColorTemperature, "inputs:enableColorTemperature"},
        {HdLightTokens->colorTemperature, "inputs:colorTemperature"},
        {HdLightTokens->diffuse, "inputs:diffuse"},
        {HdLightTokens->specular, "inputs:specular"},
        {HdLightTokens->angle, "inputs:angle"},
        {HdLightTokens->radius, "inputs:radius"},
        {HdLightTokens->width, "inputs:width"},
        {HdLightTokens->height, "inputs:height"},
        {HdLightTokens->length, "inputs:length"},
        {HdLightTokens->textureFile, "inputs:texture:file"},
        {HdLightTokens->textureFormat, "inputs:texture:format"},
        {HdLightTokens->shapingConeAngle, "inputs:shaping:cone:angle"},
        {HdLightTokens->shapingConeSoftness, "inputs:shaping:cone:softness"},
        {HdLightTokens->shapingFocus, "inputs:shaping:focus"},
        {HdLightTokens->shapingFocusTint, "inputs:shaping:focusTint"},
        {HdLightTokens->shapingIesFile, "inputs:shaping:ies:file"},
        {HdLightTokens->shapingIesAngleScale, "inputs:shaping:ies:angleScale"},
        {HdLightTokens->shapingIesNormalize, "inputs:shaping:ies:normalize"},
        {HdLightTokens->shadowEnable, "inputs:shadow:enable"},
        {HdLightTokens->shadowColor, "inputs:shadow:color"},
        {HdLightTokens->shadowDistance, "inputs:shadow:distance"},
        {HdLightTokens->shadowFalloff, "inputs:shadow:falloff"},
        {HdLightTokens->shadowFalloffGamma, "inputs:shadow:falloffGamma"},
        {TfToken("treatAsPoint"), "treatAsPoint"},
        {TfToken("treatAsLine"), "treatAsLine"},
        {TfToken("tide:caustics:emitter"), "tide:caustics:emitter"},
        {TfToken("tide:sky:model"), "tide:sky:model"},
        {TfToken("tide:sky:turbidity"), "tide:sky:turbidity"},
        {TfToken("tide:sky:groundAlbedo"), "tide:sky:groundAlbedo"},
        {TfToken("tide:sky:physicalSun"), "tide:sky:physicalSun"},
    };
    return p;
}

// Cameras: HdCameraTokens (Hydra's units: apertures and focal length in scene units, i.e. the
// USD value times GfCamera's units); the exposure controls and Tide's filter fall back to the
// prim's attribute of that name.
const std::vector<Param>& CameraParams() {
    static const std::vector<Param> p = {
        {HdCameraTokens->projection, "projection"},
        {HdCameraTokens->focalLength, "focalLength", GfCamera::FOCAL_LENGTH_UNIT},
        {HdCameraTokens->horizontalAperture, "horizontalAperture", GfCamera::APERTURE_UNIT},
        {HdCameraTokens->verticalAperture, "verticalAperture", GfCamera::APERTURE_UNIT},
        {HdCameraTokens->horizontalApertureOffset, "horizontalApertureOffset", GfCamera::APERTURE_UNIT},
        {HdCameraTokens->verticalApertureOffset, "verticalApertureOffset", GfCamera::APERTURE_UNIT},
        {HdCameraTokens->clippingRange, "clippingRange"},
        {HdCameraTokens->clipPlanes, "clippingPlanes"},
        {HdCameraTokens->fStop, "fStop"},
        {HdCameraTokens->focusDistance, "focusDistance"},
        {HdCameraTokens->shutterOpen, "shutter:open"},
        {HdCameraTokens->shutterClose, "shutter:close"},
        {HdCameraTokens->exposure, "exposure"},
        {TfToken("exposure:fStop"), "exposure:fStop"},
        {TfToken("exposure:time"), "exposure:time"},
        {TfToken("exposure:iso"), "exposure:iso"},
        {TfToken("exposure:responsivity"), "exposure:responsivity"},
        {TfToken("tide:camera:filter"), "tide:camera:filter"},
    };
    return p;
}

// Gprims' parameters: implicit shapes' sizes, and Tide's attributes of gprims (contract §4, §5),
// read with HdSceneDelegate::Get, which UsdImaging's scene delegate answers with the prim's
// attribute (UsdImaging's scene indices hand Tide's attributes over in the `tide` container).
/// Material attributes asked for by name (the scene delegate answers `Get` from them).
const std::vector<TfToken>& MaterialParams() {
    static const std::vector<TfToken> params = {TfToken("tide:wet:amount"), TfToken("tide:wet:ior"),
                                                TfToken("tide:wet:waterCompliant")};
    return params;
}

const std::vector<TfToken>& GprimParams() {
    static const std::vector<TfToken> p = {
        TfToken("radius"), TfToken("radiusTop"), TfToken("radiusBottom"), TfToken("size"), TfToken("height"),
        TfToken("axis"), TfToken("width"),
        TfToken("length"), TfToken("tide:caustics:caster"), TfToken("tide:caustics:receiver"),
        TfToken("tide:caustics:transparency"), TfToken("tide:blobby:threshold"), TfToken("tide:droplets:asVolume"),
        TfToken("tide:droplets:voxelSize"), TfToken("tide:droplets:shell"), TfToken("tide:subdivision:level")};
    return p;
}

// TideOcean's parameters (contract §5), under their attribute names.
const std::vector<TfToken>& OceanParams() {
    static const std::vector<TfToken> p = {
        TfToken("windSpeed"), TfToken("windDirection"), TfToken("spectrum"), TfToken("patchSize"),
        TfToken("resolution"), TfToken("choppiness"), TfToken("seed"), TfToken("extent"), TfToken("depth"),
        TfToken("time")};
    return p;
}

/// The prim's `name` container in the render index's terminal scene index: how UsdImaging's
/// scene indices (through Hydra's emulation) hand over what usdImagingTide's adapters publish,
/// `tide` (a prim's `tide:` attributes and relationships) and `tideOcean`. None for the prims of
/// a scene delegate such as UsdImagingDelegate, which answers Get instead.
HdContainerDataSourceHandle SceneIndexContainer(HdSceneDelegate* sd, SdfPath const& id, TfToken const& name) {
    HdSceneIndexBaseRefPtr si = sd->GetRenderIndex().GetTerminalSceneIndex();
    if (!si) return nullptr;
    HdContainerDataSourceHandle prim = si->GetPrim(id).dataSource;
    return prim ? HdContainerDataSource::Cast(prim->Get(name)) : nullptr;
}

/// The value of `container`'s child `key` at the frame's time, or empty.
VtValue ContainerValue(HdContainerDataSourceHandle const& container, TfToken const& key) {
    if (!container) return VtValue();
    HdSampledDataSourceHandle ds = HdSampledDataSource::Cast(container->Get(key));
    return ds ? ds->GetValue(0.0f) : VtValue();
}

/// `v` divided by `unit` (floats and doubles; anything else unchanged).
VtValue Unscaled(VtValue const& v, double unit) {
    if (unit == 1.0) return v;
    if (v.IsHolding<float>()) return VtValue(float(double(v.UncheckedGet<float>()) / unit));
    if (v.IsHolding<double>()) return VtValue(v.UncheckedGet<double>() / unit);
    return v;
}

}  // namespace

HdTideSnapshot::HdTideSnapshot(HdSceneDelegate* sd, SdfPath const& id, std::string const& typeId, HdDirtyBits bits,
                               int primId)
    : _path(id.GetString()) {
    using CT = HdChangeTracker;
    using tide::ChangeTracker;
    const bool isRprim = typeId != "material" && typeId != "camera" && typeId != "renderSettings" &&
                         typeId != "renderBuffer" && typeId.find("Light") == std::string::npos;
    if (isRprim) {
        if (bits & CT::DirtyTransform) {
            _PutTransformSamples(sd, id);
            _tideBits |= ChangeTracker::DirtyTransform;
        }
        if (bits & CT::DirtyVisibility) {
            _Put("visibility", VtValue(TfToken(sd->GetVisible(id) ? "inherited" : "invisible")));
            _tideBits |= ChangeTracker::DirtyVisibility;
        }
        if (bits & CT::DirtyMaterialId) {
            _Put("material", VtValue(sd->GetMaterialId(id)));
            _tideBits |= ChangeTracker::DirtyMaterialId;
        }
        if (bits & CT::DirtyPoints) {
            // every sample over the sampling window: a deforming mesh blurs. Points an ext
            // computation makes (UsdSkelImaging's skinning) are computed here, on the CPU.
            if (!_PutComputedPoints(sd, id)) {
                HdTimeSampleArray<VtValue, 4> samples;
                sd->SamplePrimvar(id, HdTokens->points, HdTideSampleOpen(), HdTideSampleClose(), &samples);
                if (_PutSamples("points", samples) == 0) _Put("points", sd->Get(id, HdTokens->points));
            }
            _tideBits |= ChangeTracker::DirtyPoints;
        }
        if (typeId == "mesh" && (bits & CT::DirtyTopology)) {
            HdMeshTopology topo = sd->GetMeshTopology(id);
            _Put("faceVertexCounts", VtValue(topo.GetFaceVertexCounts()));
            _Put("faceVertexIndices", VtValue(topo.GetFaceVertexIndices()));
            _Put("holeIndices", VtValue(topo.GetHoleIndices()));
            _Put("orientation", VtValue(topo.GetOrientation()));
            _Put("subdivisionScheme", VtValue(topo.GetScheme()));
            // the face subsets UsdImaging resolved a material for (its materialBind family), as
            // the reader sends them: `geomSubsets` (always, so that subsets removed go) and per
            // subset `<path>.indices` and `<path>.material`
            SdfPathVector subsets;
            for (HdGeomSubset const& g : topo.GetGeomSubsets()) {
                if (g.type != HdGeomSubset::TypeFaceSet) continue;
                subsets.push_back(g.id);
                _Put(g.id.GetString() + ".indices", VtValue(g.indices));
                _Put(g.id.GetString() + ".material", VtValue(g.materialId));
            }
            _Put("geomSubsets", VtValue(subsets));
            // subdivision tags, under UsdGeomMesh's own names (empty arrays when the mesh has none)
            PxOsdSubdivTags const tags = sd->GetSubdivTags(id);
            if (!tags.GetVertexInterpolationRule().IsEmpty())
                _Put("interpolateBoundary", VtValue(tags.GetVertexInterpolationRule()));
            if (!tags.GetFaceVaryingInterpolationRule().IsEmpty())
                _Put("faceVaryingLinearInterpolation", VtValue(tags.GetFaceVaryingInterpolationRule()));
            if (!tags.GetTriangleSubdivision().IsEmpty())
                _Put("triangleSubdivisionRule", VtValue(tags.GetTriangleSubdivision()));
            _Put("creaseIndices", VtValue(tags.GetCreaseIndices()));
            _Put("creaseLengths", VtValue(tags.GetCreaseLengths()));
            _Put("creaseSharpnesses", VtValue(tags.GetCreaseWeights()));
            _Put("cornerIndices", VtValue(tags.GetCornerIndices()));
            _Put("cornerSharpnesses", VtValue(tags.GetCornerWeights()));
            // (the subsets' keys are parameters to the tide:: prim)
            _tideBits |= ChangeTracker::DirtyTopology | ChangeTracker::DirtyParams;
        }
        if (typeId == "mesh" && (bits & CT::DirtyDisplayStyle)) {
            // the viewer's refinement (usdview's complexity): the subdivision level of a mesh
            // that authors no tide:subdivision:level
            _Put("displayStyle:refineLevel", VtValue(sd->GetDisplayStyle(id).refineLevel));
            _tideBits |= ChangeTracker::DirtyTopology;
        }
        if (typeId == "basisCurves" && (bits & CT::DirtyTopology)) {
            HdBasisCurvesTopology topo = sd->GetBasisCurvesTopology(id);
            // curve indices, a Hydra-only form no USD prim makes, are not read: such curves
            // arrive with more points than their counts, which the delegate reports
            _Put("curveVertexCounts", VtValue(topo.GetCurveVertexCounts()));
            _Put("type", VtValue(topo.GetCurveType()));
            _Put("basis", VtValue(topo.GetCurveBasis()));
            _Put("wrap", VtValue(topo.GetCurveWrap()));
            _tideBits |= ChangeTracker::DirtyTopology;
        }
        if (bits & (CT::DirtyPrimvar | CT::DirtyNormals | CT::DirtyWidths)) _tideBits |= ChangeTracker::DirtyPrimvar;
        // Implicit shapes' sizes arrive as DirtyPrimvar (Hydra's dirty bits translator), doubleSided
        // as DirtyDoubleSided; the caustics tags have no bit of their own and ride on both.
        if (bits & (CT::DirtyPrimvar | CT::DirtyDoubleSided)) {
            for (TfToken const& k : GprimParams()) _Put(k.GetString(), sd->Get(id, k));
            _Put("doubleSided", VtValue(sd->GetDoubleSided(id)));
            if (typeId == "tideOcean") {
                HdContainerDataSourceHandle ocean = SceneIndexContainer(sd, id, TfToken("tideOcean"));
                for (TfToken const& k : OceanParams()) {
                    VtValue v = ContainerValue(ocean, k);
                    _Put(k.GetString(), v.IsEmpty() ? sd->Get(id, k) : v);
                }
            }
            if (typeId == "mesh") {
                // UsdLuxMeshLightAPI: UsdImaging's scene indices give the mesh a `light`
                // container (its scene delegate passes none)
                HdContainerDataSourceHandle const light = SceneIndexContainer(sd, id, TfToken("light"));
                VtValue const isLight = ContainerValue(light, HdTokens->isLight);
                if (isLight.IsHolding<bool>() && isLight.UncheckedGet<bool>()) {
                    _Put("meshLight", VtValue(true));
                    for (const char* k : {"intensity", "exposure", "color", "normalize", "enableColorTemperature", "colorTemperature"})
                        _Put(std::string("inputs:") + k, ContainerValue(light, TfToken(k)));
                    _Put("light:materialSyncMode", ContainerValue(light, HdTokens->materialSyncMode));
                }
            }
            _PutTideAttributes(sd, id);
            _tideBits |= ChangeTracker::DirtyParams;
        }
        if ((bits & CT::DirtyPrimID) && primId >= 0) {
            _Put("primId", VtValue(primId));
            _tideBits |= ChangeTracker::DirtyParams;
        }
    } else if (typeId == "material") {
        VtValue res = sd->GetMaterialResource(id);
        // UsdImaging's scene indices name nodes relative to the material ("Surface"), its scene
        // delegate by their full paths: the delegate wants full paths
        auto full = [&id](SdfPath const& node) { return node.IsAbsolutePath() ? node : id.AppendPath(node); };
        if (res.IsHolding<HdMaterialNetworkMap>()) {
            for (auto const& term : res.UncheckedGet<HdMaterialNetworkMap>().map) {
                const std::string terminal = term.first == HdMaterialTerminalTokens->volume         ? "volume"
                                             : term.first == HdMaterialTerminalTokens->displacement ? "displacement"
                                                                                                    : "surface";
                HdMaterialNetwork const& net = term.second;
                if (!net.nodes.empty()) _Put(terminal, VtValue(full(net.nodes.back().path)));
                for (HdMaterialNode const& n : net.nodes) {
                    const std::string node = full(n.path).GetString();
                    _Put(node + ".info:id", VtValue(n.identifier));
                    for (auto const& p : n.parameters) {
                        const std::string name = p.first.GetString();
                        _Put(node + "." + (name.rfind("inputs:", 0) == 0 ? name : "inputs:" + name), p.second);
                    }
                }
                for (HdMaterialRelationship const& r : net.relationships) {
                    const std::string in = r.outputName.GetString();
                    _Put(full(r.outputId).GetString() + "." + (in.rfind("inputs:", 0) == 0 ? in : "inputs:" + in) + ".connect",
                         VtValue(TfToken(full(r.inputId).GetString() + ".outputs:" + r.inputName.GetString())));
                }
            }
        }
        // the material's own attributes (TideWetAPI): by name through the scene delegate, the
        // `tide` container through the scene indices
        for (TfToken const& k : MaterialParams()) _Put(k.GetString(), sd->Get(id, k));
        _PutTideAttributes(sd, id);
        _tideBits |= ChangeTracker::DirtyParams | ChangeTracker::DirtyResource;
    } else if (typeId == "camera") {
        WidenSampling(sd->GetCameraParamValue(id, HdCameraTokens->shutterOpen), sd->GetCameraParamValue(id, HdCameraTokens->shutterClose));
        for (Param const& p : CameraParams()) {
            VtValue v = Unscaled(sd->GetCameraParamValue(id, p.hd), p.unit);
            if (v.IsHolding<HdCamera::Projection>())
                v = VtValue(TfToken(v.UncheckedGet<HdCamera::Projection>() == HdCamera::Orthographic ? "orthographic"
                                                                                                   : "perspective"));
            _Put(p.key, v);
        }
        _PutTideAttributes(sd, id);
        _Put("transform", VtValue(sd->GetTransform(id)));
        _tideBits |= ChangeTracker::DirtyParams | ChangeTracker::DirtyTransform;
    } else if (typeId == "renderBuffer") {
        HdRenderBufferDescriptor d = sd->GetRenderBufferDescriptor(id);
        _store.Set(_path, "dimensions", tide::TimedValue{false, 0, tide::Value::MakeInts({d.dimensions[0], d.dimensions[1]})});
        _tideBits |= ChangeTracker::DirtyDescription;
    } else {
        for (Param const& p : LightParams()) _Put(p.key, sd->GetLightParamValue(id, p.hd));
        // an input's colour space metadata (texture:file's): not a light parameter, but a
        // `colorSpace:NAME` parameter of the light's node in its material network (both of
        // UsdImaging's paths give it there), the key the reader sends
        VtValue const res = sd->GetMaterialResource(id);
        if (res.IsHolding<HdMaterialNetworkMap>()) {
            for (auto const& [terminal, net] : res.UncheckedGet<HdMaterialNetworkMap>().map) {
                if (terminal != HdMaterialTerminalTokens->light || net.nodes.empty()) continue;
                for (auto const& [name, value] : net.nodes.back().parameters) {
                    std::string key = name.GetString();
                    if (key.rfind("colorSpace:", 0) != 0) continue;
                    if (key.rfind("colorSpace:inputs:", 0) == 0) key.erase(11, 7);
                    _Put(key, value);
                }
            }
        }
        // a dome's portals (UsdImaging's scene indices answer them, empty where none are
        // named: the dome then takes the portals no dome names)
        if (typeId == "domeLight") {
            // DomeLight_1's pole axis, as a turn of the dome before its transform
            _Put("domeOffset", sd->GetLightParamValue(id, HdLightTokens->domeOffset));
            VtValue const portals = sd->GetLightParamValue(id, HdTokens->portals);
            if (portals.IsHolding<SdfPathVector>() && !portals.UncheckedGet<SdfPathVector>().empty()) _Put("portals", portals);
        }
        _PutTideAttributes(sd, id);
        // Without the scene indices' `tide` container (UsdImaging's scene delegate, whose Get
        // reads attributes only) a sky's tide:sky:sun relationship cannot arrive: say so, and
        // the delegate takes the scene's only DistantLight as the sun
        if (!SceneIndexContainer(sd, id, TfToken("tide"))) {
            bool sky = false;
            for (const char* k : {"tide:sky:model", "tide:sky:turbidity", "tide:sky:groundAlbedo", "tide:sky:physicalSun"})
                sky = sky || !_store.Get(_path, k).IsEmpty();
            if (sky) _Put("tide:sky:sunUnreadable", VtValue(true));
        }
        // every sample over the shutter: a light that moves lights from where it is
        _PutTransformSamples(sd, id);
        _Put("visibility", VtValue(TfToken(sd->GetVisible(id) ? "inherited" : "invisible")));
        _tideBits |= ChangeTracker::DirtyParams | ChangeTracker::DirtyResource | ChangeTracker::DirtyTransform;
    }
    _sd = sd;
    _id = id;
}

void HdTideSnapshot::Add(std::string const& key, tide::TimedValue value, tide::DirtyBits bits) {
    if (value.value.IsEmpty()) return;
    _store.Set(_path, key, std::move(value));
    _tideBits |= bits;
}

void HdTideSnapshot::_PutTideAttributes(HdSceneDelegate* sd, SdfPath const& id) {
    HdContainerDataSourceHandle tide = SceneIndexContainer(sd, id, TfToken("tide"));
    if (!tide) return;
    for (TfToken const& name : tide->GetNames()) _Put(name.GetString(), ContainerValue(tide, name));
}

template <typename T, unsigned int N>
size_t HdTideSnapshot::_PutSamples(std::string const& key, HdTimeSampleArray<T, N> const& s) {
    size_t put = 0;
    for (size_t i = 0; i < s.count; ++i) {
        tide::Value v = HdTideToValue(VtValue(s.values[i]));
        if (v.IsEmpty()) continue;
        _store.Set(_path, key, tide::TimedValue{s.count > 1, double(s.times[i]), std::move(v)});
        ++put;
    }
    return put;
}

bool HdTideSnapshot::_PutComputedPoints(HdSceneDelegate* sd, SdfPath const& id) {
    HdExtComputationPrimvarDescriptorVector computed;
    for (HdInterpolation i : {HdInterpolationVertex, HdInterpolationVarying, HdInterpolationConstant})
        for (HdExtComputationPrimvarDescriptor const& d : sd->GetExtComputationPrimvarDescriptors(id, i))
            if (d.name == HdTokens->points) computed.push_back(d);
    if (computed.empty()) return false;
    HdExtComputationUtils::SampledValueStore<4> store;
    HdExtComputationUtils::SampleComputedPrimvarValues<4>(computed, sd, 4, &store);
    auto const it = store.find(HdTokens->points);
    return it != store.end() && _PutSamples("points", it->second) > 0;
}

void HdTideSnapshot::_PutTransformSamples(HdSceneDelegate* sd, SdfPath const& id) {
    HdTimeSampleArray<GfMatrix4d, 4> samples;
    sd->SampleTransform(id, HdTideSampleOpen(), HdTideSampleClose(), &samples);
    _PutSamples("transform", samples);
}

void HdTideSnapshot::_Put(std::string const& key, VtValue const& v) {
    tide::Value value = HdTideToValue(v);
    if (!value.IsEmpty()) _store.Set(_path, key, tide::TimedValue{false, 0.0, std::move(value)});
}

tide::Value HdTideSnapshot::Get(std::string const& path, std::string const& key) const { return _store.Get(path, key); }

std::vector<tide::TimedValue> HdTideSnapshot::SampleValues(std::string const& path, std::string const& key) const {
    return _store.SampleValues(path, key);
}

std::vector<std::string> HdTideSnapshot::GetKeys(std::string const& path) const { return _store.GetKeys(path); }

void HdTideSnapshot::AddInstancePrimvar(std::string const& name, tide::Primvar pv) {
    _instancePrimvars.emplace_back(name, std::move(pv));
    _tideBits |= tide::ChangeTracker::DirtyPrimvar;
}

std::vector<std::string> HdTideSnapshot::GetPrimvarNames(std::string const& path) const {
    std::vector<std::string> names;
    if (path != _path || !_sd) return names;
    for (HdInterpolation i : {HdInterpolationConstant, HdInterpolationUniform, HdInterpolationVarying,
                              HdInterpolationVertex, HdInterpolationFaceVarying})
        for (HdPrimvarDescriptor const& d : _sd->GetPrimvarDescriptors(_id, i))
            // skel: primvars are UsdSkelImaging's skinning inputs, not data to shade with
            if (d.name != HdTokens->points && !TfStringStartsWith(d.name.GetString(), "skel:"))
                names.push_back(d.name.GetString());
    for (auto const& [name, pv] : _instancePrimvars)
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    return names;
}

tide::Primvar HdTideSnapshot::GetPrimvar(std::string const& path, std::string const& name) const {
    tide::Primvar pv;
    if (path != _path || !_sd) return pv;
    auto instance = std::find_if(_instancePrimvars.begin(), _instancePrimvars.end(),
                                 [&](auto const& e) { return e.first == name; });
    auto variesOverPrim = [&] {
        for (HdInterpolation i : {HdInterpolationUniform, HdInterpolationVarying, HdInterpolationVertex, HdInterpolationFaceVarying})
            for (HdPrimvarDescriptor const& d : _sd->GetPrimvarDescriptors(_id, i))
                if (d.name.GetString() == name) return true;
        return false;
    };
    // the prim's own primvar wins where it varies over the prim
    if (instance != _instancePrimvars.end() && !variesOverPrim()) return instance->second;
    static const char* interps[] = {"constant", "uniform", "varying", "vertex", "faceVarying"};
    int k = 0;
    for (HdInterpolation i : {HdInterpolationConstant, HdInterpolationUniform, HdInterpolationVarying,
                              HdInterpolationVertex, HdInterpolationFaceVarying}) {
        for (HdPrimvarDescriptor const& d : _sd->GetPrimvarDescriptors(_id, i)) {
            if (d.name.GetString() != name) continue;
            VtIntArray indices;
            VtValue v = d.indexed ? _sd->GetIndexedPrimvar(_id, d.name, &indices) : _sd->Get(_id, d.name);
            pv.interpolation = interps[k];
            pv.data = HdTideToValue(v);
            if (pv.data.type == tide::ValueType::Float) pv.data = tide::Value::MakeFloats({float(pv.data.f)}, 1);
            pv.indexed = d.indexed;
            pv.indices.assign(indices.begin(), indices.end());
            return pv;
        }
        ++k;
    }
    return pv;
}

// ---------------------------------------------------------------------------------------------
// HdTideLightLinks

void HdTideLightLinks::SetLight(std::string const& light, TfToken const& lightLink, TfToken const& shadowLink) {
    std::lock_guard<std::mutex> lock(_mutex);
    std::array<TfToken, 2> const links = {lightLink, shadowLink};
    auto it = _lights.find(light);
    if (it != _lights.end() && it->second == links) return;
    _lights[light] = links;
    _changed = true;
}

void HdTideLightLinks::RemoveLight(std::string const& light) {
    std::lock_guard<std::mutex> lock(_mutex);
    _lights.erase(light);
    // a light made again at this path starts without collections in the Rust delegate
    _sent.erase({light, 0});
    _sent.erase({light, 1});
}

/// Sets `map[key]` to `value` (an empty value: no entry); returns whether that changed it.
template <typename Map, typename Value>
static bool HdTideAssign(Map& map, std::string const& key, Value value) {
    auto it = map.find(key);
    if (it == map.end() ? value.empty() : it->second == value) return false;
    if (value.empty()) map.erase(key);
    else map[key] = std::move(value);
    return true;
}

void HdTideLightLinks::SetCategories(std::string const& rprim, VtArray<TfToken> const& categories) {
    std::set<TfToken> c(categories.begin(), categories.end());
    std::lock_guard<std::mutex> lock(_mutex);
    if (HdTideAssign(_categories, rprim, std::move(c))) _changed = true;
}

void HdTideLightLinks::SetInstanceCategories(std::string const& rprim, std::vector<std::set<TfToken>> categories) {
    std::lock_guard<std::mutex> lock(_mutex);
    if (HdTideAssign(_instanceCategories, rprim, std::move(categories))) _changed = true;
}

void HdTideLightLinks::RemoveRprim(std::string const& rprim) {
    std::lock_guard<std::mutex> lock(_mutex);
    if (_categories.erase(rprim)) _changed = true;
    if (_instanceCategories.erase(rprim)) _changed = true;
    _instanced.erase(rprim);
    _pending.erase(rprim);
}

void HdTideLightLinks::SetInstanced(std::string const& rprim, bool instanced) {
    std::lock_guard<std::mutex> lock(_mutex);
    if (instanced) _instanced.insert(rprim);
    else _instanced.erase(rprim);
}

void HdTideLightLinks::RequestInstanceRefresh() {
    std::lock_guard<std::mutex> lock(_mutex);
    _refresh = true;
}

std::vector<std::string> HdTideLightLinks::TakeInstanceRefresh() {
    std::lock_guard<std::mutex> lock(_mutex);
    if (!_refresh) {
        // a whole sync has passed since the rprims were marked: what did not sync will not
        _pending.clear();
        return {};
    }
    _refresh = false;
    _pending.insert(_instanced.begin(), _instanced.end());
    return {_instanced.begin(), _instanced.end()};
}

void HdTideLightLinks::Refreshed(std::string const& rprim) {
    std::lock_guard<std::mutex> lock(_mutex);
    _pending.erase(rprim);
}

bool HdTideLightLinks::RefreshPending() {
    std::lock_guard<std::mutex> lock(_mutex);
    return _refresh || !_pending.empty();
}

bool HdTideLightLinks::Committed() {
    std::lock_guard<std::mutex> lock(_mutex);
    return _committed;
}

/// The name instance k of an instanced rprim stands for in collections (its `instancePaths`).
static std::string HdTideInstanceName(std::string const& rprim, size_t k) {
    return rprim + "[" + std::to_string(k) + "]";
}

void HdTideLightLinks::Forward(tide::RenderParam& param) {
    std::lock_guard<std::mutex> lock(_mutex);
    _committed = true;
    if (!_changed) return;
    _changed = false;
    static const char* const names[2] = {"lightLink", "shadowLink"};
    for (auto const& [light, tokens] : _lights) {
        for (int which = 0; which < 2; ++which) {
            Sent now;
            now.everything = tokens[which].IsEmpty();
            if (!now.everything) {
                TfToken const& token = tokens[which];
                for (auto const& [rprim, categories] : _categories)
                    if (categories.count(token) && !_instanceCategories.count(rprim)) now.includes.push_back(rprim);
                for (auto const& [rprim, instances] : _instanceCategories) {
                    auto const own = _categories.find(rprim);
                    const bool all = own != _categories.end() && own->second.count(token);
                    for (size_t k = 0; k < instances.size(); ++k)
                        if (all || instances[k].count(token)) now.includes.push_back(HdTideInstanceName(rprim, k));
                }
            }
            auto const sent = _sent.find({light, which});
            // nothing sent yet and the light reaches everything: the delegate's default already
            if (sent == _sent.end() ? now.everything : sent->second == now) continue;
            const std::string base = std::string("collection:") + names[which] + ":";
            auto put = [&](std::string const& key, tide::Value v) {
                param.Forward(light, base + key, tide::TimedValue{false, 0.0, std::move(v)});
            };
            put("includes", tide::Value::MakePaths(now.includes));
            put("excludes", tide::Value::MakePaths({}));
            put("includeRoot", tide::Value::MakeBool(now.everything));
            put("expansionRule", tide::Value::MakeToken(now.everything ? "expandPrims" : "explicitOnly"));
            _sent[{light, which}] = std::move(now);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Prims: each Hd prim owns its tide:: prim.

namespace {

HdDirtyBits const kAllRprimBits = HdChangeTracker::AllSceneDirtyBits;
TfToken const kOpenVdbAsset("openvdbAsset");
TfToken const kFieldIndex("fieldIndex");

/// A volume's fields as the reader sends them: per field binding N of an `openvdbAsset` field,
/// `field:N` (the resolved file), `field:N:fieldName` (the grid's name, else N),
/// `field:N:fieldIndex` and `field:N:transform` (the field's placement relative to the volume);
/// the density grid is read (once per file, grid and index) and handed to the delegate.
void SyncVolumeFields(HdSceneDelegate* sd, SdfPath const& id, HdTideSnapshot* snapshot, HdTideShared& shared) {
    using tide::ChangeTracker;
    const std::string volume = id.GetString();
    const GfMatrix4d toVolume = sd->GetTransform(id).GetInverse();
    for (HdVolumeFieldDescriptor const& f : sd->GetVolumeFieldDescriptors(id)) {
        const std::string name = f.fieldName.GetString();
        const std::string field = f.fieldId.GetString();
        if (f.fieldPrimType != kOpenVdbAsset) {
            shared.param->AddProblem(volume, "field:" + name, field + " is not an OpenVDB asset");
            continue;
        }
        const VtValue file = sd->Get(f.fieldId, HdFieldTokens->filePath);
        std::string resolved, authored;
        if (file.IsHolding<SdfAssetPath>()) {
            resolved = file.UncheckedGet<SdfAssetPath>().GetResolvedPath();
            authored = file.UncheckedGet<SdfAssetPath>().GetAssetPath();
        }
        if (resolved.empty()) {
            shared.param->AddProblem(field, "filePath", "cannot find VDB file '" + authored + "'; field dropped");
            continue;
        }
        const VtValue gridName = sd->Get(f.fieldId, HdFieldTokens->fieldName);
        std::string grid = gridName.IsHolding<TfToken>() ? gridName.UncheckedGet<TfToken>().GetString()
                           : gridName.IsHolding<std::string>() ? gridName.UncheckedGet<std::string>()
                                                               : std::string();
        if (grid.empty()) grid = name;
        const VtValue indexValue = sd->Get(f.fieldId, kFieldIndex);
        const int64_t index = indexValue.IsHolding<int>() ? indexValue.UncheckedGet<int>() : 0;
        const std::string key = "field:" + name;
        auto add = [&](std::string const& k, tide::Value v) {
            snapshot->Add(k, tide::TimedValue{false, 0.0, std::move(v)}, ChangeTracker::DirtyParams);
        };
        add(key, tide::Value::MakeAsset(resolved));
        add(key + ":fieldName", tide::Value::MakeToken(grid));
        add(key + ":fieldIndex", tide::Value::MakeInt(index));
        add(key + ":transform", HdTideToValue(VtValue(sd->GetTransform(f.fieldId) * toVolume)));
        if (name == "density") {
            std::lock_guard<std::mutex> lock(shared.vdbMutex);
            tide::LoadVdbFor(*shared.param, resolved, grid, index);
        }
    }
}

/// What every Hd prim of this delegate has: the tide:: prim it forwards to.
template <typename P>
class HdTideLink {
public:
    virtual ~HdTideLink() = default;
    virtual P* TidePrim() const = 0;
};

template <typename Base>
class HdTideRprim final : public Base, public HdTideLink<tide::Rprim> {
public:
    HdTideRprim(SdfPath const& id, std::string typeId, tide::Rprim* prim, HdTideShared* shared)
        : Base(id), _typeId(std::move(typeId)), _prim(prim), _shared(shared) {}
    tide::Rprim* TidePrim() const override { return _prim; }

    HdDirtyBits GetInitialDirtyBitsMask() const override { return kAllRprimBits; }
    void Sync(HdSceneDelegate* sd, HdRenderParam*, HdDirtyBits* dirtyBits, TfToken const&) override {
        using CT = HdChangeTracker;
        SdfPath const& id = Base::GetId();
        Base::_UpdateInstancer(sd, dirtyBits);
        SdfPath const& instancerId = Base::GetInstancerId();
        HdInstancer::_SyncInstancerAndParents(sd->GetRenderIndex(), instancerId);
        HdTideSnapshot snapshot(sd, id, _typeId, *dirtyBits, Base::GetPrimId());
        // the rprim's render tag (UsdImaging's, from its purpose; the render index reads it and
        // clears DirtyRenderTag before the sync): the passes whose tags include it render it
        snapshot.Add("renderTag", tide::TimedValue{false, 0.0, tide::Value::MakeToken(Base::GetRenderTag().GetString())},
                     tide::ChangeTracker::DirtyParams);
        {
            std::lock_guard<std::mutex> lock(_shared->tagMutex);
            _shared->forwardedTags[this] = Base::GetRenderTag();
        }
        if (!instancerId.IsEmpty() && (*dirtyBits & (CT::DirtyInstancer | CT::DirtyInstanceIndex | CT::DirtyTransform))) {
            if (auto* inst = dynamic_cast<HdTideInstancer*>(sd->GetRenderIndex().GetInstancer(instancerId))) {
                HdTideInstanceSamples const s = inst->SampleInstanceTransforms(id);
                for (size_t i = 0; i < s.times.size(); ++i)
                    snapshot.Add("instanceTransforms",
                                 tide::TimedValue{s.times.size() > 1, double(s.times[i]), HdTideToValue(VtValue(s.transforms[i]))},
                                 tide::ChangeTracker::DirtyInstancer);
                for (auto& [name, pv] : inst->InstancePrimvars(id)) snapshot.AddInstancePrimvar(name, std::move(pv));
            }
        }
        if (*dirtyBits & (CT::DirtyInstancer | CT::DirtyInstanceIndex)) _shared->links.SetInstanced(id.GetString(), !instancerId.IsEmpty());
        if (!instancerId.IsEmpty() && (*dirtyBits & (CT::DirtyInstancer | CT::DirtyInstanceIndex | CT::DirtyCategories))) {
            if (auto* inst = dynamic_cast<HdTideInstancer*>(sd->GetRenderIndex().GetInstancer(instancerId))) {
                // per-instance light-link categories: each instance then stands for itself in
                // the lights' collections (an empty list: the rprim for all of them)
                std::vector<std::set<TfToken>> categories = inst->InstanceCategories(id);
                std::vector<std::string> names;
                if (std::any_of(categories.begin(), categories.end(), [](auto const& c) { return !c.empty(); })) {
                    for (size_t k = 0; k < categories.size(); ++k) names.push_back(HdTideInstanceName(id.GetString(), k));
                } else {
                    categories.clear();
                }
                _shared->links.SetInstanceCategories(id.GetString(), std::move(categories));
                _shared->links.Refreshed(id.GetString());
                snapshot.Add("instancePaths", tide::TimedValue{false, 0.0, tide::Value::MakePaths(std::move(names))},
                             tide::ChangeTracker::DirtyInstancer);
            }
        }
        if (_typeId == "volume" && (*dirtyBits & (CT::DirtyVolumeField | CT::DirtyTransform)))
            SyncVolumeFields(sd, id, &snapshot, *_shared);
        if (*dirtyBits & CT::DirtyCategories) _shared->links.SetCategories(id.GetString(), sd->GetCategories(id));
        if (_typeId == "mesh" && (*dirtyBits & CT::DirtyPrimvar)) {
            // a mesh light's link categories, as a light's (the `light` container UsdImaging's
            // scene indices give a MeshLightAPI mesh)
            HdContainerDataSourceHandle const light = SceneIndexContainer(sd, id, TfToken("light"));
            VtValue const isLight = ContainerValue(light, HdTokens->isLight);
            auto token = [&](TfToken const& key) {
                VtValue const v = ContainerValue(light, key);
                return v.IsHolding<TfToken>() ? v.UncheckedGet<TfToken>() : TfToken();
            };
            if (isLight.IsHolding<bool>() && isLight.UncheckedGet<bool>())
                _shared->links.SetLight(id.GetString(), token(HdTokens->lightLink), token(HdTokens->shadowLink));
            else
                _shared->links.RemoveLight(id.GetString());
        }
        tide::DirtyBits bits = snapshot.TideBits();
        _prim->Sync(snapshot, &bits);
        *dirtyBits &= ~HdChangeTracker::AllSceneDirtyBits;
    }
    TfTokenVector const& GetBuiltinPrimvarNames() const override {
        static const TfTokenVector names = {HdTokens->points, HdTokens->normals, HdTokens->widths};
        return names;
    }

protected:
    HdDirtyBits _PropagateDirtyBits(HdDirtyBits bits) const override { return bits; }
    void _InitRepr(TfToken const&, HdDirtyBits*) override {}

private:
    std::string _typeId;
    tide::Rprim* _prim;
    HdTideShared* _shared;
};

/// A camera (HdCamera, whose own Sync keeps the values Hydra reads back for framing), a light
/// (HdLight) or a material (HdMaterial): Hydra casts sprims of these types to these classes.
template <typename Base>
class HdTideSprim final : public Base, public HdTideLink<tide::Sprim> {
public:
    /// `links`: where a light records its link categories (nullptr for cameras and materials).
    HdTideSprim(SdfPath const& id, std::string typeId, tide::Sprim* prim, HdTideLightLinks* links = nullptr)
        : Base(id), _typeId(std::move(typeId)), _prim(prim), _links(links) {}
    tide::Sprim* TidePrim() const override { return _prim; }
    HdDirtyBits GetInitialDirtyBitsMask() const override { return Base::AllDirty; }
    void Sync(HdSceneDelegate* sd, HdRenderParam* param, HdDirtyBits* dirtyBits) override {
        const HdDirtyBits hdBits = *dirtyBits;
        if constexpr (std::is_same_v<Base, HdCamera>) HdCamera::Sync(sd, param, dirtyBits);
        HdTideSnapshot snapshot(sd, Base::GetId(), _typeId, hdBits);
        tide::DirtyBits bits = snapshot.TideBits();
        _prim->Sync(snapshot, &bits);
        if (_links) {
            // a changed collection, or a light made after the first sync (made again, as
            // UsdImaging does on a resync): native instances' categories may have changed
            if ((hdBits & HdLight::DirtyCollection) && (_synced || _links->Committed())) _links->RequestInstanceRefresh();
            _synced = true;
            auto token = [&](TfToken const& name) {
                VtValue const v = sd->GetLightParamValue(Base::GetId(), name);
                return v.IsHolding<TfToken>() ? v.UncheckedGet<TfToken>() : TfToken();
            };
            _links->SetLight(Base::GetId().GetString(), token(HdTokens->lightLink), token(HdTokens->shadowLink));
        }
        *dirtyBits = Base::Clean;
    }

private:
    bool _synced = false;
    std::string _typeId;
    tide::Sprim* _prim;
    HdTideLightLinks* _links;
};

/// An `openvdbAsset` field: its values are read by the volumes bound to it (Hydra marks them
/// DirtyVolumeField when the field changes), so the field itself keeps nothing.
class HdTideField final : public HdField {
public:
    using HdField::HdField;
    HdDirtyBits GetInitialDirtyBitsMask() const override { return AllDirty; }
    void Sync(HdSceneDelegate*, HdRenderParam*, HdDirtyBits* dirtyBits) override { *dirtyBits = Clean; }
};

/// A renderSettings bprim (UsdRenderSettings as Hydra flattens it) forwarded to a Tide
/// renderSettings prim at its path, with the keys the usd-core reader sends: its `tide:`
/// settings, `includedPurposes`, `renderingColorSpace`, and from its first product `camera`,
/// `pixelAspectRatio`, `dataWindowNDC`, `disableMotionBlur`, `disableDepthOfField` and the
/// product's own `tide:` settings (over the settings' own); every
/// product as `products`, `<P>.productName`, `<P>.camera`, `<P>.resolution`, `<P>.orderedVars`
/// and `<V>.sourceName`. The image size stays the bound buffers' (no top-level `resolution`).
class HdTideRenderSettings final : public HdRenderSettings {
public:
    HdTideRenderSettings(SdfPath const& id, tide::Sprim* prim, HdTideRenderDelegate* delegate)
        : HdRenderSettings(id), _prim(prim), _delegate(delegate) {}
    tide::Sprim* TidePrim() const { return _prim; }

protected:
    void _Sync(HdSceneDelegate*, HdRenderParam*, const HdDirtyBits*) override {
        const std::string path = GetId().GetString();
        tide::MemorySceneSource source;
        auto put = [&](std::string const& key, tide::Value v) {
            if (!v.IsEmpty()) source.Set(path, key, tide::TimedValue{false, 0.0, std::move(v)});
        };
        for (auto const& [key, value] : GetNamespacedSettings())
            if (key.rfind("tide:", 0) == 0) put(key, HdTideToValue(value));
        // unauthored purposes arrive empty: leave the delegate's default (default, render)
        if (!GetIncludedPurposes().empty()) put("includedPurposes", HdTideToValue(VtValue(GetIncludedPurposes())));
        const TfToken space = GetRenderingColorSpace();
        put("renderingColorSpace", tide::Value::MakeToken(space.IsEmpty() ? "lin_rec709" : space.GetString()));
        RenderProducts const& products = GetRenderProducts();
        std::vector<std::string> productPaths;
        for (RenderProduct const& p : products) {
            const std::string pp = p.productPath.GetString();
            productPaths.push_back(pp);
            put(pp + ".productName", tide::Value::MakeString(p.name.GetString()));
            if (!p.cameraPath.IsEmpty()) put(pp + ".camera", tide::Value::MakePath(p.cameraPath.GetString()));
            put(pp + ".resolution", tide::Value::MakeInts({p.resolution[0], p.resolution[1]}));
            std::vector<std::string> vars;
            for (RenderProduct::RenderVar const& v : p.renderVars) {
                vars.push_back(v.varPath.GetString());
                put(v.varPath.GetString() + ".sourceName", tide::Value::MakeString(v.sourceName));
            }
            put(pp + ".orderedVars", tide::Value::MakePaths(std::move(vars)));
        }
        put("products", tide::Value::MakePaths(std::move(productPaths)));
        if (!products.empty()) {
            RenderProduct const& p = products.front();
            if (!p.cameraPath.IsEmpty()) put("camera", tide::Value::MakePath(p.cameraPath.GetString()));
            put("pixelAspectRatio", tide::Value::MakeFloat(p.pixelAspectRatio));
            if (!p.aspectRatioConformPolicy.IsEmpty())
                put("aspectRatioConformPolicy", tide::Value::MakeToken(p.aspectRatioConformPolicy.GetString()));
            GfRange2f const& w = p.dataWindowNDC;
            if (!w.IsEmpty())
                put("dataWindowNDC", tide::Value::MakeFloats({w.GetMin()[0], w.GetMin()[1], w.GetMax()[0], w.GetMax()[1]}, 4));
            put("disableMotionBlur", tide::Value::MakeBool(p.disableMotionBlur));
            put("disableDepthOfField", tide::Value::MakeBool(p.disableDepthOfField));
            // the product's own tide: settings override the settings' (as the reader does)
            for (auto const& [key, value] : p.namespacedSettings)
                if (key.rfind("tide:", 0) == 0) put(key, HdTideToValue(value));
        }
        tide::DirtyBits bits = tide::ChangeTracker::DirtyParams;
        _prim->Sync(source, &bits);
        _delegate->SetActiveSettings(path, IsActive());
    }

private:
    tide::Sprim* _prim;
    HdTideRenderDelegate* _delegate;
};

class HdTideRenderBuffer final : public HdRenderBuffer {
public:
    HdTideRenderBuffer(SdfPath const& id, tide::RenderBuffer* buffer) : HdRenderBuffer(id), _buffer(buffer) {}
    tide::RenderBuffer* TideBuffer() const { return _buffer; }
    /// Tide renders float32, and int32 for an Int32 buffer (Hydra's ids): a request for another
    /// format gets float32 with as many components, and GetFormat says what the mapped pixels
    /// really are.
    bool Allocate(GfVec3i const& dims, HdFormat format, bool multiSampled) override {
        tide::Format f = tide::Format::Float32Vec4;
        switch (HdGetComponentCount(format)) {
        case 1: f = format == HdFormatInt32 ? tide::Format::Int32 : tide::Format::Float32; break;
        case 2: f = tide::Format::Float32Vec2; break;
        case 3: f = tide::Format::Float32Vec3; break;
        default: break;
        }
        return _buffer->Allocate(dims[0], dims[1], dims[2], f, multiSampled);
    }
    unsigned int GetWidth() const override { return _buffer->GetWidth(); }
    unsigned int GetHeight() const override { return _buffer->GetHeight(); }
    unsigned int GetDepth() const override { return 1; }
    /// The format of the pixels Map returns (after a Resolve, the bound AOV's channels; int32
    /// in an Int32 buffer, else float32).
    HdFormat GetFormat() const override {
        const bool ints = _buffer->GetFormat() == tide::Format::Int32;
        switch (_buffer->GetChannels()) {
        case 0: return HdFormatInvalid;
        case 1: return ints ? HdFormatInt32 : HdFormatFloat32;
        case 2: return HdFormatFloat32Vec2;
        case 3: return HdFormatFloat32Vec3;
        default: return HdFormatFloat32Vec4;
        }
    }
    bool IsMultiSampled() const override { return false; }
    void* Map() override { return _buffer->Map(); }
    void Unmap() override { _buffer->Unmap(); }
    bool IsMapped() const override { return _buffer->IsMapped(); }
    void Resolve() override { _buffer->Resolve(); }
    bool IsConverged() const override { return _buffer->IsConverged(); }

private:
    void _Deallocate() override {}
    tide::RenderBuffer* _buffer;
};

/// A binding's clearValue as a number per channel (empty: none, or a type Tide does not know).
std::vector<double> ClearValues(VtValue const& v) {
    if (v.IsHolding<float>()) return {v.UncheckedGet<float>()};
    if (v.IsHolding<double>()) return {v.UncheckedGet<double>()};
    if (v.IsHolding<int>()) return {double(v.UncheckedGet<int>())};
    if (v.IsHolding<GfVec2f>()) {
        GfVec2f c = v.UncheckedGet<GfVec2f>();
        return {c[0], c[1]};
    }
    if (v.IsHolding<GfVec3f>()) {
        GfVec3f c = v.UncheckedGet<GfVec3f>();
        return {c[0], c[1], c[2]};
    }
    if (v.IsHolding<GfVec4f>()) {
        GfVec4f c = v.UncheckedGet<GfVec4f>();
        return {c[0], c[1], c[2], c[3]};
    }
    return {};
}

class HdTideRenderPass final : public HdRenderPass {
public:
    HdTideRenderPass(HdRenderIndex* index, HdRprimCollection const& collection, std::shared_ptr<tide::RenderPass> pass,
                     HdTideRenderDelegate const* delegate)
        : HdRenderPass(index, collection), _pass(std::move(pass)), _delegate(delegate) {}
    // not while instanced rprims are still to read their categories again (they sync on the
    // next execution)
    bool IsConverged() const override { return !_delegate->InstanceRefreshPending() && _pass->IsConverged(); }

protected:
    void _Execute(HdRenderPassStateSharedPtr const& state, TfTokenVector const& renderTags) override {
        tide::RenderPassState s;
        s.hydra = true;
        // the viewer's purposes, as the tags of the rprims it shows
        for (TfToken const& t : renderTags) s.renderTags.push_back(t.GetString());
        s.renderSettings = _delegate->SettingsPathForPass();
        if (HdCamera const* cam = state->GetCamera()) {
            s.camera = cam->GetId().GetString();
            // the pass's framing and window policy, as the projection Hydra's tasks (picking)
            // assume the image was made with
            const GfMatrix4d proj = state->GetProjectionMatrix();
            s.projection.assign(proj.data(), proj.data() + 16);
        }
        for (HdRenderPassAovBinding const& b : state->GetAovBindings()) {
            auto* rb = dynamic_cast<HdTideRenderBuffer*>(b.renderBuffer);
            s.aovBindings.push_back({b.aovName.GetString(), b.renderBufferId.GetString(), rb ? rb->TideBuffer() : nullptr, ClearValues(b.clearValue)});
        }
        std::string error;
        if (!_pass->Execute(s, &error)) TF_WARN("Tide: %s", error.c_str());
    }

private:
    std::shared_ptr<tide::RenderPass> _pass;
    HdTideRenderDelegate const* _delegate;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// HdTideRenderDelegate

static TfTokenVector Tokens(std::vector<std::string> const& v) {
    TfTokenVector t;
    for (auto const& s : v) t.emplace_back(s);
    return t;
}

/// Where the delegate's render settings live in the Rust delegate: the path the usd-core reader
/// uses when a stage has no UsdRenderSettings prim.
static const char kSettingsPath[] = "/Render/__TideSettings";

/// TideRenderSettingsAPI (schemas/schema.usda): the settings the delegate forwards, with the
/// schema's defaults. Resolution is not among them: Tide renders at the bound buffers' size.
static HdRenderSettingDescriptorList const& Descriptors() {
    static const HdRenderSettingDescriptorList d = {
        {"Integrator (path, caustics)", TfToken("tide:integrator"), VtValue(TfToken("caustics"))},
        {"Samples per pixel", TfToken("tide:samples"), VtValue(64)},
        {"Maximum path depth", TfToken("tide:maxDepth"), VtValue(64)},
        {"Seed", TfToken("tide:seed"), VtValue(0)},
        {"Time budget (s, 0 = none)", TfToken("tide:time:budget"), VtValue(0.0f)},
        {"Adaptive threshold (0 = off)", TfToken("tide:adaptive:threshold"), VtValue(0.0f)},
        {"Adaptive minimum samples (0 = 16)", TfToken("tide:adaptive:minSamples"), VtValue(0)},
        {"Pixel filter (gaussian, box, triangle)", TfToken("tide:pixelFilter"), VtValue(TfToken("box"))},
        {"Pixel filter width (pixels, 0 = the filter's own)", TfToken("tide:pixelFilter:width"), VtValue(0.0f)},
    };
    return d;
}

HdTideRenderDelegate::HdTideRenderDelegate() : HdTideRenderDelegate(HdRenderSettingsMap()) {}

HdTideRenderDelegate::HdTideRenderDelegate(HdRenderSettingsMap const& settingsMap)
    : HdRenderDelegate(settingsMap), _tide(new tide::RenderDelegate()), _registry(new HdResourceRegistry()),
      _shared(new HdTideShared()) {
    _shared->param = _tide->GetRenderParam();
    _PopulateDefaultSettings(Descriptors());
    _settingsPrim = _tide->CreateSprim("renderSettings", kSettingsPath);
    _SyncSettings();
}

HdTideRenderDelegate::~HdTideRenderDelegate() {
    if (_settingsPrim) _tide->DestroySprim(_settingsPrim);
}

void HdTideRenderDelegate::_SyncSettings() {
    if (!_settingsPrim) return;
    for (HdRenderSettingDescriptor const& d : Descriptors()) {
        VtValue const v = GetRenderSetting(d.key);
        tide::Value value = HdTideToValue(v);
        if (value.IsEmpty()) {
            if (!v.IsEmpty())
                TF_WARN("Tide: %s: %s: a %s is not a setting value (the previous one stays)", kSettingsPath,
                        d.key.GetText(), v.GetTypeName().c_str());
            continue;
        }
        _tide->SetRenderSetting(d.key.GetString(), value);
        _settingsSource.Set(kSettingsPath, d.key.GetString(), tide::TimedValue{false, 0.0, std::move(value)});
    }
    tide::DirtyBits bits = tide::ChangeTracker::DirtyParams;
    _settingsPrim->Sync(_settingsSource, &bits);
}

void HdTideRenderDelegate::SetRenderSetting(TfToken const& key, VtValue const& value) {
    const unsigned int before = GetRenderSettingsVersion();
    HdRenderDelegate::SetRenderSetting(key, value);
    if (GetRenderSettingsVersion() != before) _SyncSettings();
}

HdRenderSettingDescriptorList HdTideRenderDelegate::GetRenderSettingDescriptors() const { return Descriptors(); }

TfTokenVector HdTideRenderDelegate::GetRenderSettingsNamespaces() const { return {TfToken("tide")}; }

void HdTideRenderDelegate::SetActiveSettings(std::string const& path, bool active) {
    std::lock_guard<std::mutex> lock(_activeMutex);
    if (active) _activeSettings = path;
    else if (_activeSettings == path) _activeSettings.clear();
}

std::string HdTideRenderDelegate::SettingsPathForPass() const {
    std::lock_guard<std::mutex> lock(_activeMutex);
    return _activeSettings.empty() ? std::string(kSettingsPath) : _activeSettings;
}

bool HdTideRenderDelegate::Stop(bool blocking) {
    // the render thread ends its pass at its next pixel; blocking or not, nothing is
    // published after this returns (the buffers keep what the render's last pass published),
    // and blocking, no worker renders either
    return _tide->Stop(blocking);
}

VtDictionary HdTideRenderDelegate::GetRenderStats() const {
    VtDictionary stats;
    std::shared_ptr<tide::RenderPass> pass = _lastPass.lock();
    if (!pass) return stats;
    stats["percentDone"] = VtValue(100.0 * pass->GetProgress());
    stats["tide:converged"] = VtValue(pass->IsConverged());
    for (std::string const& kv : pass->GetSummary()) {
        const size_t eq = kv.find('=');
        if (eq != std::string::npos) stats["tide:" + kv.substr(0, eq)] = VtValue(kv.substr(eq + 1));
    }
    const std::string error = pass->GetError();
    if (!error.empty()) stats["tide:error"] = VtValue(error);
    return stats;
}

TfTokenVector const& HdTideRenderDelegate::GetSupportedRprimTypes() const {
    static const TfTokenVector t = Tokens(_tide->GetSupportedRprimTypes());
    return t;
}
TfTokenVector const& HdTideRenderDelegate::GetSupportedSprimTypes() const {
    // Hydra's renderSettings prims are bprims (HdRenderSettings; see CreateBprim).
    static const TfTokenVector t = [this] {
        TfTokenVector types;
        // UsdImaging makes PortalLights `light` sprims
        for (std::string const& s : _tide->GetSupportedSprimTypes())
            if (s != "renderSettings") types.emplace_back(s == "portalLight" ? HdPrimTypeTokens->light.GetString() : s);
        types.push_back(HdPrimTypeTokens->extComputation);
        return types;
    }();
    return t;
}
TfTokenVector const& HdTideRenderDelegate::GetSupportedBprimTypes() const {
    static const TfTokenVector t = [this] {
        TfTokenVector types = Tokens(_tide->GetSupportedBprimTypes());
        types.push_back(HdPrimTypeTokens->renderSettings);
        types.push_back(kOpenVdbAsset);
        return types;
    }();
    return t;
}

HdResourceRegistrySharedPtr HdTideRenderDelegate::GetResourceRegistry() const { return _registry; }

HdRenderPassSharedPtr HdTideRenderDelegate::CreateRenderPass(HdRenderIndex* index, HdRprimCollection const& collection) {
    std::shared_ptr<tide::RenderPass> pass = _tide->CreateRenderPass();
    _lastPass = pass;
    return std::make_shared<HdTideRenderPass>(index, collection, std::move(pass), this);
}

HdInstancer* HdTideRenderDelegate::CreateInstancer(HdSceneDelegate* delegate, SdfPath const& id) {
    return new HdTideInstancer(delegate, id);
}
void HdTideRenderDelegate::DestroyInstancer(HdInstancer* instancer) { delete instancer; }

HdRprim* HdTideRenderDelegate::CreateRprim(TfToken const& typeId, SdfPath const& rprimId) {
    tide::Rprim* prim = _tide->CreateRprim(typeId.GetString(), rprimId.GetString());
    if (!prim) return nullptr;
    // tagged hidden until its first sync gives its tag: Hydra creates the rprims of every
    // purpose but syncs only those of the tags it tracks, and an rprim never synced (a
    // sphere's defaults: a unit ball at the origin) must not be rendered
    _tide->GetRenderParam()->Forward(rprimId.GetString(), "renderTag",
                                     tide::TimedValue{false, 0.0, tide::Value::MakeToken(HdRenderTagTokens->hidden.GetString())});
    HdTideShared* shared = _shared.get();
    if (typeId == HdPrimTypeTokens->mesh) return new HdTideRprim<HdMesh>(rprimId, typeId.GetString(), prim, shared);
    if (typeId == HdPrimTypeTokens->basisCurves)
        return new HdTideRprim<HdBasisCurves>(rprimId, typeId.GetString(), prim, shared);
    if (typeId == HdPrimTypeTokens->points) return new HdTideRprim<HdPoints>(rprimId, typeId.GetString(), prim, shared);
    if (typeId == HdPrimTypeTokens->volume) return new HdTideRprim<HdVolume>(rprimId, typeId.GetString(), prim, shared);
    return new HdTideRprim<HdRprim>(rprimId, typeId.GetString(), prim, shared);
}

void HdTideRenderDelegate::DestroyRprim(HdRprim* rPrim) {
    {
        std::lock_guard<std::mutex> lock(_shared->tagMutex);
        _shared->forwardedTags.erase(rPrim);
    }
    _shared->links.RemoveRprim(rPrim->GetId().GetString());
    _shared->links.RemoveLight(rPrim->GetId().GetString());
    if (auto* link = dynamic_cast<HdTideLink<tide::Rprim>*>(rPrim)) _tide->DestroyRprim(link->TidePrim());
    delete rPrim;
}

HdSprim* HdTideRenderDelegate::CreateSprim(TfToken const& typeId, SdfPath const& sprimId) {
    // computations (skinning) stay in Hydra: rprims evaluate them when they sync
    if (typeId == HdPrimTypeTokens->extComputation) return new HdExtComputation(sprimId);
    // UsdImaging gives only PortalLights the generic `light` type
    if (typeId == HdPrimTypeTokens->light) {
        tide::Sprim* portal = _tide->CreateSprim("portalLight", sprimId.GetString());
        return portal ? new HdTideSprim<HdLight>(sprimId, "portalLight", portal) : nullptr;
    }
    tide::Sprim* prim = _tide->CreateSprim(typeId.GetString(), sprimId.GetString());
    if (!prim) return nullptr;
    if (typeId == HdPrimTypeTokens->camera) return new HdTideSprim<HdCamera>(sprimId, typeId.GetString(), prim);
    if (typeId == HdPrimTypeTokens->material) return new HdTideSprim<HdMaterial>(sprimId, typeId.GetString(), prim);
    return new HdTideSprim<HdLight>(sprimId, typeId.GetString(), prim, &_shared->links);
}

HdSprim* HdTideRenderDelegate::CreateFallbackSprim(TfToken const&) { return nullptr; }

void HdTideRenderDelegate::DestroySprim(HdSprim* sPrim) {
    if (dynamic_cast<HdLight*>(sPrim)) _shared->links.RemoveLight(sPrim->GetId().GetString());
    if (auto* link = dynamic_cast<HdTideLink<tide::Sprim>*>(sPrim)) _tide->DestroySprim(link->TidePrim());
    delete sPrim;
}

HdBprim* HdTideRenderDelegate::CreateBprim(TfToken const& typeId, SdfPath const& bprimId) {
    if (typeId == kOpenVdbAsset) return new HdTideField(bprimId);
    if (typeId == HdPrimTypeTokens->renderSettings) {
        tide::Sprim* prim = _tide->CreateSprim("renderSettings", bprimId.GetString());
        return prim ? new HdTideRenderSettings(bprimId, prim, this) : nullptr;
    }
    tide::Bprim* prim = _tide->CreateBprim(typeId.GetString(), bprimId.GetString());
    return prim ? new HdTideRenderBuffer(bprimId, static_cast<tide::RenderBuffer*>(prim)) : nullptr;
}

HdBprim* HdTideRenderDelegate::CreateFallbackBprim(TfToken const&) { return nullptr; }

void HdTideRenderDelegate::DestroyBprim(HdBprim* bPrim) {
    if (auto* b = dynamic_cast<HdTideRenderBuffer*>(bPrim)) _tide->DestroyBprim(b->TideBuffer());
    if (auto* r = dynamic_cast<HdTideRenderSettings*>(bPrim)) {
        SetActiveSettings(r->GetId().GetString(), false);
        _tide->DestroySprim(r->TidePrim());
    }
    delete bPrim;
}

void HdTideRenderDelegate::CommitResources(HdChangeTracker* tracker) {
    // instanced rprims read their instances' categories again on the next sync
    if (tracker)
        for (std::string const& rprim : _shared->links.TakeInstanceRefresh())
            tracker->MarkRprimDirty(SdfPath(rprim), HdChangeTracker::DirtyCategories);
    // every prim has synced: the light links' member sets are complete
    _shared->links.Forward(*_tide->GetRenderParam());
    // render tags the render index changed without syncing the prim (its new purpose is not
    // tracked): forwarded here, so that the passes stop rendering it under its old tag
    {
        std::lock_guard<std::mutex> lock(_shared->tagMutex);
        for (auto& [rprim, tag] : _shared->forwardedTags) {
            if (rprim->GetRenderTag() == tag) continue;
            tag = rprim->GetRenderTag();
            _tide->GetRenderParam()->Forward(rprim->GetId().GetString(), "renderTag",
                                             tide::TimedValue{false, 0.0, tide::Value::MakeToken(tag.GetString())});
        }
    }
    _tide->CommitResources();
    for (tide::Problem const& p : _tide->TakeProblems())
        TF_WARN("Tide: %s: %s: %s", p.prim.c_str(), p.attribute.c_str(), p.message.c_str());
}

/// Hydra's conventions (hdx's picking and selection read them): `depth` is clip-space depth in
/// [0, 1] (1 where nothing is hit), `cameraDepth` the distance along the view axis, the ids
/// (`primId`, `instanceId`, `elementId`: the face of a mesh, the curve, the point) int32, -1
/// where nothing is hit; rows run from the bottom. An AOV Tide does not render gets an invalid
/// format, so that a task controller leaves it out.
HdAovDescriptor HdTideRenderDelegate::GetDefaultAovDescriptor(TfToken const& name) const {
    if (name == HdAovTokens->color) return HdAovDescriptor(HdFormatFloat32Vec4, false, VtValue(GfVec4f(0.0f)));
    if (name == HdAovTokens->depth) return HdAovDescriptor(HdFormatFloat32, false, VtValue(1.0f));
    if (name == HdAovTokens->cameraDepth) return HdAovDescriptor(HdFormatFloat32, false, VtValue(0.0f));
    if (name == HdAovTokens->primId || name == HdAovTokens->instanceId || name == HdAovTokens->elementId)
        return HdAovDescriptor(HdFormatInt32, false, VtValue(-1));
    switch (tide::RenderDelegate::AovChannels(name.GetString())) {
    case 1: return HdAovDescriptor(HdFormatFloat32, false, VtValue(0.0f));
    case 3: return HdAovDescriptor(HdFormatFloat32Vec3, false, VtValue(GfVec3f(0.0f)));
    default: return HdAovDescriptor();
    }
}

PXR_NAMESPACE_CLOSE_SCOPE
