//! HdTideRendererPlugin: creates HdTideRenderDelegate instances.
#include "rendererPlugin.h"
#include "hdTide.h"

#include "pxr/imaging/hd/rendererPluginRegistry.h"

PXR_NAMESPACE_OPEN_SCOPE

TF_REGISTRY_FUNCTION(TfType) { HdRendererPluginRegistry::Define<HdTideRendererPlugin>(); }

HdRenderDelegate* HdTideRendererPlugin::CreateRenderDelegate() { return new HdTideRenderDelegate(); }

HdRenderDelegate* HdTideRendererPlugin::CreateRenderDelegate(HdRenderSettingsMap const& settingsMap) {
    return new HdTideRenderDelegate(settingsMap);
}

void HdTideRendererPlugin::DeleteRenderDelegate(HdRenderDelegate* renderDelegate) { delete renderDelegate; }

bool HdTideRendererPlugin::IsSupported(bool) const { return true; }

PXR_NAMESPACE_CLOSE_SCOPE
