// usdImagingTide's adapters (see adapters.h).
#include "adapters.h"

#include "pxr/base/tf/stringUtils.h"
#include "pxr/base/tf/type.h"
#include "pxr/imaging/hd/cameraSchema.h"
#include "pxr/imaging/hd/collectionsSchema.h"
#include "pxr/imaging/hd/lightSchema.h"
#include "pxr/imaging/hd/materialSchema.h"
#include "pxr/imaging/hd/overlayContainerDataSource.h"
#include "pxr/imaging/hd/primvarsSchema.h"
#include "pxr/imaging/hd/retainedDataSource.h"
#include "pxr/usd/usd/relationship.h"
#include "pxr/usd/usd/stage.h"
#include "pxr/usd/usdGeom/camera.h"
#include "pxr/usd/usdGeom/metrics.h"
#include "pxr/usd/usdShade/material.h"
#include "pxr/usdImaging/usdImaging/dataSourceAttribute.h"
#include "pxr/usdImaging/usdImaging/dataSourceGprim.h"
#include "pxr/usdImaging/usdImaging/dataSourceStageGlobals.h"
#include "pxr/usdImaging/usdImaging/indexProxy.h"
#include "pxr/usdImaging/usdImaging/tokens.h"

#include <algorithm>

PXR_NAMESPACE_OPEN_SCOPE

TF_DEFINE_PRIVATE_TOKENS(_tokens,
    (tideOcean)
    (tide)
    (time)
    ((causticsCaster, "tide:caustics:caster"))
    ((causticsEmitter, "tide:caustics:emitter"))
);

namespace {

/// The TideOcean parameters besides `time` (contract §5), under their attribute names.
const TfTokenVector& OceanParams() {
    static const TfTokenVector p = {TfToken("windSpeed"), TfToken("windDirection"), TfToken("spectrum"),
                                    TfToken("patchSize"), TfToken("resolution"), TfToken("choppiness"),
                                    TfToken("seed"), TfToken("extent"), TfToken("depth")};
    return p;
}

bool IsOceanParam(TfToken const& name) {
    return name == _tokens->time || std::find(OceanParams().begin(), OceanParams().end(), name) != OceanParams().end();
}

/// The ocean's time in seconds at stage time `t`: the authored `time`, else t / timeCodesPerSecond
/// (what the usd-core reader sends).
double OceanTime(UsdPrim const& prim, UsdTimeCode t) {
    UsdAttribute attr = prim.GetAttribute(_tokens->time);
    double v = 0.0;
    if (attr && attr.HasAuthoredValue()) {
        VtValue value;
        if (attr.Get(&value, t) && value.CanCast<double>()) return value.Cast<double>().UncheckedGet<double>();
    }
    const double tcps = prim.GetStage()->GetTimeCodesPerSecond();
    if (!t.IsDefault() && tcps > 0.0) v = t.GetValue() / tcps;
    return v;
}

/// The ocean's time as a scene-index data source: follows the stage time (and the shutter
/// offsets Hydra asks for) when `time` is not authored.
class OceanTimeDataSource final : public HdTypedSampledDataSource<double> {
public:
    HD_DECLARE_DATASOURCE(OceanTimeDataSource);

    VtValue GetValue(Time shutterOffset) override { return VtValue(GetTypedValue(shutterOffset)); }
    double GetTypedValue(Time shutterOffset) override {
        const UsdTimeCode t = _globals.GetTime();
        return OceanTime(_prim, t.IsNumeric() ? UsdTimeCode(t.GetValue() + shutterOffset) : t);
    }
    bool GetContributingSampleTimesForInterval(Time, Time, std::vector<Time>*) override { return false; }

private:
    OceanTimeDataSource(UsdPrim const& prim, const UsdImagingDataSourceStageGlobals& globals)
        : _prim(prim), _globals(globals) {}
    UsdPrim _prim;
    const UsdImagingDataSourceStageGlobals& _globals;
};

}  // namespace

TF_REGISTRY_FUNCTION(TfType) {
    {
        using Adapter = UsdImagingTideOceanAdapter;
        TfType t = TfType::Define<Adapter, TfType::Bases<Adapter::BaseAdapter>>();
        t.SetFactory<UsdImagingPrimAdapterFactory<Adapter>>();
    }
    {
        using Adapter = UsdImagingTideAttributesAdapter;
        TfType t = TfType::Define<Adapter, TfType::Bases<Adapter::BaseAdapter>>();
        t.SetFactory<UsdImagingAPISchemaAdapterFactory<Adapter>>();
    }
}

// ---------------------------------------------------------------------------------------------
// UsdImagingTideOceanAdapter

UsdImagingTideOceanAdapter::~UsdImagingTideOceanAdapter() = default;

TfTokenVector UsdImagingTideOceanAdapter::GetImagingSubprims(UsdPrim const&) { return {TfToken()}; }

TfToken UsdImagingTideOceanAdapter::GetImagingSubprimType(UsdPrim const&, TfToken const& subprim) {
    return subprim.IsEmpty() ? _tokens->tideOcean : TfToken();
}

HdContainerDataSourceHandle UsdImagingTideOceanAdapter::GetImagingSubprimData(
    UsdPrim const& prim, TfToken const& subprim, const UsdImagingDataSourceStageGlobals& stageGlobals) {
    if (!subprim.IsEmpty()) return nullptr;
    TfTokenVector names;
    std::vector<HdDataSourceBaseHandle> values;
    for (TfToken const& name : OceanParams()) {
        if (UsdAttribute attr = prim.GetAttribute(name)) {
            names.push_back(name);
            values.push_back(UsdImagingDataSourceAttributeNew(attr, stageGlobals, prim.GetPath(),
                                                              HdDataSourceLocator(_tokens->tideOcean, name)));
        }
    }
    names.push_back(_tokens->time);
    values.push_back(OceanTimeDataSource::New(prim, stageGlobals));
    // the time follows the stage's unless authored constant
    UsdAttribute time = prim.GetAttribute(_tokens->time);
    if (!time || !time.HasAuthoredValue() || time.ValueMightBeTimeVarying())
        stageGlobals.FlagAsTimeVarying(prim.GetPath(), HdDataSourceLocator(_tokens->tideOcean, _tokens->time));
    return HdOverlayContainerDataSource::New(
        HdRetainedContainerDataSource::New(_tokens->tideOcean,
                                           HdRetainedContainerDataSource::New(names.size(), names.data(), values.data())),
        UsdImagingDataSourceGprim::New(prim.GetPath(), prim, stageGlobals));
}

HdDataSourceLocatorSet UsdImagingTideOceanAdapter::InvalidateImagingSubprim(
    UsdPrim const& prim, TfToken const& subprim, TfTokenVector const& properties,
    UsdImagingPropertyInvalidationType invalidationType) {
    if (!subprim.IsEmpty()) return HdDataSourceLocatorSet();
    HdDataSourceLocatorSet locators = UsdImagingDataSourceGprim::Invalidate(prim, subprim, properties, invalidationType);
    for (TfToken const& p : properties) {
        if (IsOceanParam(p)) {
            locators.insert(HdDataSourceLocator(_tokens->tideOcean, p));
            // Hydra's emulation turns only known locators into dirty bits: a primvar's is
            // DirtyPrimvar, on which the plugin re-reads the ocean's parameters
            locators.insert(HdPrimvarsSchema::GetDefaultLocator().Append(p));
        }
    }
    return locators;
}

bool UsdImagingTideOceanAdapter::IsSupported(UsdImagingIndexProxy const* index) const {
    return index->IsRprimTypeSupported(_tokens->tideOcean);
}

SdfPath UsdImagingTideOceanAdapter::Populate(UsdPrim const& prim, UsdImagingIndexProxy* index,
                                             UsdImagingInstancerContext const* instancerContext) {
    return _AddRprim(_tokens->tideOcean, prim, index, GetMaterialUsdPath(prim), instancerContext);
}

void UsdImagingTideOceanAdapter::TrackVariability(UsdPrim const& prim, SdfPath const& cachePath,
                                                  HdDirtyBits* timeVaryingBits,
                                                  UsdImagingInstancerContext const* instancerContext) const {
    BaseAdapter::TrackVariability(prim, cachePath, timeVaryingBits, instancerContext);
    for (TfToken const& name : OceanParams())
        _IsVarying(prim, name, HdChangeTracker::DirtyPrimvar, UsdImagingTokens->usdVaryingPrimvar, timeVaryingBits,
                   false);
    // an unauthored time follows the stage's
    UsdAttribute time = prim.GetAttribute(_tokens->time);
    if (!time || !time.HasAuthoredValue()) *timeVaryingBits |= HdChangeTracker::DirtyPrimvar;
    else _IsVarying(prim, _tokens->time, HdChangeTracker::DirtyPrimvar, UsdImagingTokens->usdVaryingPrimvar,
                    timeVaryingBits, false);
}

HdDirtyBits UsdImagingTideOceanAdapter::ProcessPropertyChange(UsdPrim const& prim, SdfPath const& cachePath,
                                                              TfToken const& propertyName) {
    if (IsOceanParam(propertyName)) return HdChangeTracker::DirtyPrimvar;
    return BaseAdapter::ProcessPropertyChange(prim, cachePath, propertyName);
}

VtValue UsdImagingTideOceanAdapter::Get(UsdPrim const& prim, SdfPath const& cachePath, TfToken const& key,
                                        UsdTimeCode time, VtIntArray* outIndices) const {
    if (key == _tokens->time) return VtValue(OceanTime(prim, time));
    return BaseAdapter::Get(prim, cachePath, key, time, outIndices);
}

VtValue UsdImagingTideOceanAdapter::GetPoints(UsdPrim const&, UsdTimeCode) const {
    // the surface is built by the renderer around its camera
    return VtValue(VtVec3fArray());
}

// ---------------------------------------------------------------------------------------------
// UsdImagingTideAttributesAdapter

UsdImagingTideAttributesAdapter::~UsdImagingTideAttributesAdapter() = default;

HdContainerDataSourceHandle UsdImagingTideAttributesAdapter::GetImagingSubprimData(
    UsdPrim const& prim, TfToken const& subprim, TfToken const&, const UsdImagingDataSourceStageGlobals& stageGlobals) {
    if (!subprim.IsEmpty()) return nullptr;
    TfTokenVector names;
    std::vector<HdDataSourceBaseHandle> values;
    for (UsdProperty const& prop : prim.GetPropertiesInNamespace(_tokens->tide)) {
        const TfToken name = prop.GetName();
        if (UsdAttribute attr = prop.As<UsdAttribute>()) {
            if (!attr.HasValue()) continue;
            // an applied TideCausticsAPI's fallback `false` is no explicit `false`: an unauthored
            // caster or emitter role leaves the object or light untagged (as the reader sends it)
            if ((name == _tokens->causticsCaster || name == _tokens->causticsEmitter) && !attr.HasAuthoredValue())
                continue;
            names.push_back(name);
            values.push_back(UsdImagingDataSourceAttributeNew(attr, stageGlobals, prim.GetPath(),
                                                              HdDataSourceLocator(_tokens->tide, name)));
        } else if (UsdRelationship rel = prop.As<UsdRelationship>()) {
            // as the reader sends it: the first forwarded target, or an empty path
            SdfPathVector targets;
            rel.GetForwardedTargets(&targets);
            names.push_back(name);
            values.push_back(HdRetainedTypedSampledDataSource<SdfPath>::New(targets.empty() ? SdfPath() : targets[0]));
        }
    }
    // a camera also carries the stage's frame rate: Hydra's shutter is in frames, and nothing
    // else tells a render delegate how long a frame is
    // and the stage's metres per unit where authored (what the contract gives in metres is
    // converted with it; USD's fallback, centimetres, is not taken for an unauthored stage),
    // and its up axis (water depth is measured down it)
    if (prim.IsA<UsdGeomCamera>()) {
        names.push_back(TfToken("timeCodesPerSecond"));
        values.push_back(HdRetainedTypedSampledDataSource<double>::New(prim.GetStage()->GetTimeCodesPerSecond()));
        if (UsdGeomStageHasAuthoredMetersPerUnit(prim.GetStage())) {
            names.push_back(TfToken("metersPerUnit"));
            values.push_back(HdRetainedTypedSampledDataSource<double>::New(UsdGeomGetStageMetersPerUnit(prim.GetStage())));
        }
        names.push_back(TfToken("upAxis"));
        values.push_back(HdRetainedTypedSampledDataSource<TfToken>::New(UsdGeomGetStageUpAxis(prim.GetStage())));
    }
    if (names.empty()) return nullptr;
    return HdRetainedContainerDataSource::New(
        _tokens->tide, HdRetainedContainerDataSource::New(names.size(), names.data(), values.data()));
}

HdDataSourceLocatorSet UsdImagingTideAttributesAdapter::InvalidateImagingSubprim(
    UsdPrim const& prim, TfToken const& subprim, TfToken const&, TfTokenVector const& properties,
    UsdImagingPropertyInvalidationType invalidationType) {
    HdDataSourceLocatorSet locators;
    if (!subprim.IsEmpty()) return locators;
    for (TfToken const& p : properties) {
        // UsdImaging v24.08's CollectionAPI adapter invalidates on properties named
        // "collections:NAME:…", where CollectionAPI's are "collection:NAME:…": an edited
        // collection (a light's lightLink includes) reached no scene index. Its locator here.
        if (TfStringStartsWith(p.GetString(), "collection:")) {
            std::vector<std::string> const parts = TfStringSplit(p.GetString(), ":");
            if (parts.size() >= 3)
                locators.insert(HdDataSourceLocator(HdCollectionsSchemaTokens->collections, TfToken(parts[1])));
            continue;
        }
        if (!TfStringStartsWith(p.GetString(), "tide:")) continue;
        // a new or removed property changes the container's names
        if (invalidationType == UsdImagingPropertyInvalidationType::Resync)
            locators.insert(HdDataSourceLocator(_tokens->tide));
        else locators.insert(HdDataSourceLocator(_tokens->tide, p));
        // Hydra's emulation turns only known locators into dirty bits: these make gprims
        // (DirtyPrimvar), lights and cameras (DirtyParams) re-read their `tide:` values
        locators.insert(HdPrimvarsSchema::GetDefaultLocator().Append(p));
        locators.insert(HdLightSchema::GetDefaultLocator().Append(p));
        locators.insert(HdCameraSchema::GetDefaultLocator().Append(p));
        // and materials (DirtyResource) their TideWetAPI values
        if (prim.IsA<UsdShadeMaterial>()) locators.insert(HdMaterialSchema::GetDefaultLocator());
    }
    return locators;
}

PXR_NAMESPACE_CLOSE_SCOPE
