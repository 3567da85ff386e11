//! HdTideRenderSettingsFilterPlugin: the scene index plugin Hydra applications load with Tide
//! ("loadWithRenderer": "Tide" in plugInfo.json). It appends HdsiRenderSettingsFilteringSceneIndex,
//! which gives renderSettings prims their `active` flag from the scene globals (the render
//! settings prim the application makes active, as usdview's engine does with the stage's
//! `renderSettingsPrimPath`) and keeps only their `tide:` namespaced settings. Without it no
//! renderSettings prim ever became active through UsdImaging's scene indices, so a stage's (and
//! its products') `tide:` settings were not rendered with.
#include "pxr/imaging/hd/retainedDataSource.h"
#include "pxr/imaging/hd/sceneIndexPlugin.h"
#include "pxr/imaging/hd/sceneIndexPluginRegistry.h"
#include "pxr/imaging/hdsi/renderSettingsFilteringSceneIndex.h"
#include "pxr/pxr.h"

PXR_NAMESPACE_OPEN_SCOPE

class HdTideRenderSettingsFilterPlugin final : public HdSceneIndexPlugin {
protected:
    HdSceneIndexBaseRefPtr _AppendSceneIndex(HdSceneIndexBaseRefPtr const& inputScene,
                                             HdContainerDataSourceHandle const& inputArgs) override {
        return HdsiRenderSettingsFilteringSceneIndex::New(inputScene, inputArgs);
    }
};

TF_REGISTRY_FUNCTION(TfType) { HdSceneIndexPluginRegistry::Define<HdTideRenderSettingsFilterPlugin>(); }

TF_REGISTRY_FUNCTION(HdSceneIndexPlugin) {
    HdContainerDataSourceHandle const args = HdRetainedContainerDataSource::New(
        HdsiRenderSettingsFilteringSceneIndexTokens->namespacePrefixes,
        HdRetainedTypedSampledDataSource<VtArray<TfToken>>::New(VtArray<TfToken>{TfToken("tide")}));
    HdSceneIndexPluginRegistry::GetInstance().RegisterSceneIndexForRenderer(
        "Tide", TfToken("HdTideRenderSettingsFilterPlugin"), args, /* insertionPhase = */ 0,
        HdSceneIndexPluginRegistry::InsertionOrderAtEnd);
}

PXR_NAMESPACE_CLOSE_SCOPE
