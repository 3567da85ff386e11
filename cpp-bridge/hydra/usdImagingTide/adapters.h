// usdImagingTide: UsdImaging adapters that bring Tide's own USD data into Hydra, for the
// HdTideRendererPlugin to forward (see ../../README.md, "UsdImaging adapters"):
//
// * UsdImagingTideOceanAdapter: `TideOcean` prims become `tideOcean` rprims. Through UsdImaging's
//   scene delegate their parameters are answered by Get (the prim's attributes; `time`, when not
//   authored, is the stage time in seconds); through its scene indices they sit in a `tideOcean`
//   container beside the gprim's data (transform, visibility, material binding, primvars).
// * UsdImagingTideAttributesAdapter: a keyless API-schema adapter (it sees every prim) that, for
//   UsdImaging's scene indices, publishes a prim's `tide:` attributes and relationships in a
//   `tide` container, as the usd-core reader sends them. UsdImaging's scene delegate has no such
//   channel; the plugin asks it for the `tide:` attributes it knows by name instead. It also
//   invalidates a prim's `collections` when a `collection:` property changes, which UsdImaging's
//   own CollectionAPI adapter (v24.08) misses.
#pragma once

#include "pxr/pxr.h"
#include "pxr/usdImaging/usdImaging/apiSchemaAdapter.h"
#include "pxr/usdImaging/usdImaging/gprimAdapter.h"

PXR_NAMESPACE_OPEN_SCOPE

class UsdImagingTideOceanAdapter : public UsdImagingGprimAdapter {
public:
    using BaseAdapter = UsdImagingGprimAdapter;
    ~UsdImagingTideOceanAdapter() override;

    // scene indices
    TfTokenVector GetImagingSubprims(UsdPrim const& prim) override;
    TfToken GetImagingSubprimType(UsdPrim const& prim, TfToken const& subprim) override;
    HdContainerDataSourceHandle GetImagingSubprimData(UsdPrim const& prim, TfToken const& subprim,
                                                      const UsdImagingDataSourceStageGlobals& stageGlobals) override;
    HdDataSourceLocatorSet InvalidateImagingSubprim(UsdPrim const& prim, TfToken const& subprim,
                                                    TfTokenVector const& properties,
                                                    UsdImagingPropertyInvalidationType invalidationType) override;

    // scene delegate
    bool IsSupported(UsdImagingIndexProxy const* index) const override;
    SdfPath Populate(UsdPrim const& prim, UsdImagingIndexProxy* index,
                     UsdImagingInstancerContext const* instancerContext = nullptr) override;
    void TrackVariability(UsdPrim const& prim, SdfPath const& cachePath, HdDirtyBits* timeVaryingBits,
                          UsdImagingInstancerContext const* instancerContext = nullptr) const override;
    HdDirtyBits ProcessPropertyChange(UsdPrim const& prim, SdfPath const& cachePath,
                                      TfToken const& propertyName) override;
    VtValue Get(UsdPrim const& prim, SdfPath const& cachePath, TfToken const& key, UsdTimeCode time,
                VtIntArray* outIndices) const override;
    VtValue GetPoints(UsdPrim const& prim, UsdTimeCode time) const override;
};

class UsdImagingTideAttributesAdapter : public UsdImagingAPISchemaAdapter {
public:
    using BaseAdapter = UsdImagingAPISchemaAdapter;
    ~UsdImagingTideAttributesAdapter() override;

    HdContainerDataSourceHandle GetImagingSubprimData(UsdPrim const& prim, TfToken const& subprim,
                                                      TfToken const& appliedInstanceName,
                                                      const UsdImagingDataSourceStageGlobals& stageGlobals) override;
    HdDataSourceLocatorSet InvalidateImagingSubprim(UsdPrim const& prim, TfToken const& subprim,
                                                    TfToken const& appliedInstanceName,
                                                    TfTokenVector const& properties,
                                                    UsdImagingPropertyInvalidationType invalidationType) override;
};

PXR_NAMESPACE_CLOSE_SCOPE
