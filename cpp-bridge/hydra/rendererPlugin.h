//! HdTideRendererPlugin: registers Tide with Hydra (display name "Tide").
#pragma once

#include "pxr/imaging/hd/rendererPlugin.h"
#include "pxr/pxr.h"

PXR_NAMESPACE_OPEN_SCOPE

class HdTideRendererPlugin final : public HdRendererPlugin {
public:
    HdTideRendererPlugin() = default;
    HdRenderDelegate* CreateRenderDelegate() override;
    HdRenderDelegate* CreateRenderDelegate(HdRenderSettingsMap const& settingsMap) override;
    void DeleteRenderDelegate(HdRenderDelegate* renderDelegate) override;
    bool IsSupported(bool gpuEnabled = true) const override;

private:
    HdTideRendererPlugin(const HdTideRendererPlugin&) = delete;
    HdTideRendererPlugin& operator=(const HdTideRendererPlugin&) = delete;
};

PXR_NAMESPACE_CLOSE_SCOPE
