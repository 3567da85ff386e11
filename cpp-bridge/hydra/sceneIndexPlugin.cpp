//! The scene index plugins Hydra applications load with Tide ("loadWithRenderer": "Tide" in
//! plugInfo.json):
//!
//! - HdTideRenderSettingsFilterPlugin appends HdsiRenderSettingsFilteringSceneIndex, which
//!   gives renderSettings prims their `active` flag from the scene globals (the render settings
//!   prim the application makes active, as usdview's engine does with the stage's
//!   `renderSettingsPrimPath`) and keeps only their `tide:` namespaced settings. Without it no
//!   renderSettings prim ever became active through UsdImaging's scene indices, so a stage's
//!   (and its products') `tide:` settings were not rendered with.
//! - HdTideLightLinkingPlugin inserts HdsiLightLinkingSceneIndex, which turns the lights'
//!   `lightLink` / `shadowLink` collections into the category tokens lights and geometry carry
//!   (what the render delegate reads as with a scene delegate). Without it UsdImaging's scene
//!   indices carried no light linking: every light reached everything. (In OpenUSD v24.08 it
//!   gives instanced prims no categories: linked lights miss them.)
#include "pxr/imaging/hd/retainedDataSource.h"
#include "pxr/imaging/hd/sceneIndexPlugin.h"
#include "pxr/imaging/hd/sceneIndexPluginRegistry.h"
#include "pxr/imaging/hdsi/lightLinkingSceneIndex.h"
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

class HdTideLightLinkingPlugin final : public HdSceneIndexPlugin {
protected:
    HdSceneIndexBaseRefPtr _AppendSceneIndex(HdSceneIndexBaseRefPtr const& inputScene,
                                             HdContainerDataSourceHandle const& inputArgs) override {
        return HdsiLightLinkingSceneIndex::New(inputScene, inputArgs);
    }
};

TF_REGISTRY_FUNCTION(TfType) {
    HdSceneIndexPluginRegistry::Define<HdTideRenderSettingsFilterPlugin>();
    HdSceneIndexPluginRegistry::Define<HdTideLightLinkingPlugin>();
}

TF_REGISTRY_FUNCTION(HdSceneIndexPlugin) {
    HdContainerDataSourceHandle const args = HdRetainedContainerDataSource::New(
        HdsiRenderSettingsFilteringSceneIndexTokens->namespacePrefixes,
        HdRetainedTypedSampledDataSource<VtArray<TfToken>>::New(VtArray<TfToken>{TfToken("tide")}));
    HdSceneIndexPluginRegistry::GetInstance().RegisterSceneIndexForRenderer(
        "Tide", TfToken("HdTideRenderSettingsFilterPlugin"), args, /* insertionPhase = */ 0,
        HdSceneIndexPluginRegistry::InsertionOrderAtEnd);
    // after procedurals (which may make lights and geometry); Hydra's own light and geometry
    // prim types (the defaults, nullptr arguments)
    HdSceneIndexPluginRegistry::GetInstance().RegisterSceneIndexForRenderer(
        "Tide", TfToken("HdTideLightLinkingPlugin"), nullptr, /* insertionPhase = */ 4,
        HdSceneIndexPluginRegistry::InsertionOrderAtStart);
}

PXR_NAMESPACE_CLOSE_SCOPE
