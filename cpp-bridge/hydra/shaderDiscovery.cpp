//! HdTideShaderDiscovery: an Sdr (Ndr) discovery plugin that gives a Hydra application the shader
//! definitions of TideWater and TideMedium (schemas/shaders/*.usda, installed into the hdTide
//! plugin's resources/shaders), so that UsdImaging accepts materials whose info:id names them
//! (it drops shader nodes Sdr does not know). Declared in plugInfo.json as an NdrDiscoveryPlugin.
#include "pxr/base/plug/plugin.h"
#include "pxr/base/plug/registry.h"
#include "pxr/base/tf/diagnostic.h"
#include "pxr/base/tf/stringUtils.h"
#include "pxr/pxr.h"
#include "pxr/usd/ndr/discoveryPlugin.h"
#include "pxr/usd/usd/stage.h"
#include "pxr/usd/usdShade/shader.h"
#include "pxr/usd/usdShade/shaderDefUtils.h"

PXR_NAMESPACE_OPEN_SCOPE

class HdTideShaderDiscovery final : public NdrDiscoveryPlugin {
public:
    NdrNodeDiscoveryResultVec DiscoverNodes(const Context&) override {
        NdrNodeDiscoveryResultVec results;
        const std::string dir = ShaderDir();
        if (dir.empty()) return results;
        for (const char* id : {"TideWater", "TideMedium"}) {
            const std::string path = TfStringCatPaths(dir, std::string(id) + ".usda");
            UsdStageRefPtr stage = UsdStage::Open(path);
            UsdShadeShader shader(stage ? stage->GetPrimAtPath(SdfPath::AbsoluteRootPath().AppendChild(TfToken(id))) : UsdPrim());
            if (!shader) {
                TF_WARN("Tide: no shader definition %s in %s", id, path.c_str());
                continue;
            }
            for (NdrNodeDiscoveryResult& r : UsdShadeShaderDefUtils::GetNodeDiscoveryResults(shader, path))
                results.push_back(std::move(r));
        }
        return results;
    }
    const NdrStringVec& GetSearchURIs() const override {
        static const NdrStringVec uris{ShaderDir()};
        return uris;
    }

private:
    /// resources/shaders of the hdTide plugin, or "" (with a warning) when it is not found.
    static std::string ShaderDir() {
        PlugPluginPtr plugin = PlugRegistry::GetInstance().GetPluginWithName("hdTide");
        if (!plugin) {
            TF_WARN("Tide: the hdTide plugin is not registered; TideWater and TideMedium stay unknown to Sdr");
            return std::string();
        }
        return TfStringCatPaths(plugin->GetResourcePath(), "shaders");
    }
};

NDR_REGISTER_DISCOVERY_PLUGIN(HdTideShaderDiscovery)

PXR_NAMESPACE_CLOSE_SCOPE
