//! hdTide: Hd* classes mapped onto Tide's tide:: classes. Each Hd prim's Sync takes a
//! snapshot of what its dirty bits name from the HdSceneDelegate (a tide::SceneSource) and
//! hands it to the matching tide:: prim, which forwards it to the Rust delegate.
#pragma once

#include "instancer.h"

#include "tide/renderDelegate.h"
#include "tide/sceneSource.h"

#include "pxr/imaging/hd/basisCurves.h"
#include "pxr/imaging/hd/bprim.h"
#include "pxr/imaging/hd/extComputation.h"
#include "pxr/imaging/hd/extComputationUtils.h"
#include "pxr/imaging/hd/mesh.h"
#include "pxr/imaging/hd/points.h"
#include "pxr/imaging/hd/renderBuffer.h"
#include "pxr/imaging/hd/renderDelegate.h"
#include "pxr/imaging/hd/renderPass.h"
#include "pxr/imaging/hd/rprim.h"
#include "pxr/imaging/hd/sprim.h"
#include "pxr/imaging/hd/timeSampleArray.h"
#include "pxr/pxr.h"

#include <array>
#include <map>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <set>
#include <string>
#include <vector>

PXR_NAMESPACE_OPEN_SCOPE

/// Converts a VtValue into a tide::Value (Empty when the type has no protocol equivalent).
tide::Value HdTideToValue(VtValue const& v);

/// The window (frame offsets from the current time) over which the plugin asks for transform
/// and primvar samples: at least [−1, 1], widened to every synced camera's shutter. The Rust
/// delegate keeps the samples that bracket the shutter it renders. Scene indices answer only
/// what is asked for (without a window, one sample); UsdImaging's scene delegate answers over
/// the shutter of the camera its application set for sampling.
float HdTideSampleOpen();
float HdTideSampleClose();

/// The values of one prim read from an HdSceneDelegate, as a tide::SceneSource.
class HdTideSnapshot final : public tide::SceneSource {
public:
    /// `primId`: the rprim's id in the render index (forwarded as `primId`), or -1.
    HdTideSnapshot(HdSceneDelegate* sd, SdfPath const& id, std::string const& typeId, HdDirtyBits bits,
                   int primId = -1);
    tide::Value Get(std::string const& path, std::string const& key) const override;
    std::vector<tide::TimedValue> SampleValues(std::string const& path, std::string const& key) const override;
    std::vector<std::string> GetKeys(std::string const& path) const override;
    std::vector<std::string> GetPrimvarNames(std::string const& path) const override;
    tide::Primvar GetPrimvar(std::string const& path, std::string const& name) const override;

    /// The tide:: dirty bits matching the Hd ones that were read.
    tide::DirtyBits TideBits() const { return _tideBits; }
    /// Adds a sample of `key` read outside the constructor, with the tide:: bits it dirties.
    void Add(std::string const& key, tide::TimedValue value, tide::DirtyBits bits);
    /// Adds a per-instance primvar (interpolation `instance`). It replaces the prim's own primvar
    /// of that name where that one is constant, and gives way where it varies.
    void AddInstancePrimvar(std::string const& name, tide::Primvar pv);

private:
    /// `key` as the samples of `s` (frame offsets), or one untimed value when there is one;
    /// empty values are skipped. Returns how many were put.
    template <typename T, unsigned int N>
    size_t _PutSamples(std::string const& key, HdTimeSampleArray<T, N> const& s);
    /// `points` an ext computation makes (every sample); false when none does.
    bool _PutComputedPoints(HdSceneDelegate* sd, SdfPath const& id);
    /// `transform` as every sample of `SampleTransform` (frame offsets; one untimed when still).
    void _PutTransformSamples(HdSceneDelegate* sd, SdfPath const& id);
    void _Put(std::string const& key, VtValue const& v);
    /// Every `tide:` attribute and relationship that usdImagingTide published for the prim in the
    /// render index's scene indices, under its name (relationships as their first target's path).
    void _PutTideAttributes(HdSceneDelegate* sd, SdfPath const& id);
    tide::MemorySceneSource _store;
    std::string _path;
    HdSceneDelegate* _sd = nullptr;
    SdfPath _id;
    tide::DirtyBits _tideBits = 0;
    std::vector<std::pair<std::string, tide::Primvar>> _instancePrimvars;
};

/// Hydra's light linking turned into the collections Tide's lights take. A light names a
/// category per link (`lightLink`, `shadowLink`: a collection token, empty when it reaches
/// everything); rprims list their categories (HdSceneDelegate::GetCategories). Prims record
/// what they read during Sync (in parallel); Forward, at commit, sends each light whose member
/// set changed `collection:<link>:includes` (the member rprims' paths, or instances' names),
/// `:excludes` (none),
/// `:includeRoot` (false) and `:expansionRule` (explicitOnly), or, once its token is empty
/// again, a collection that includes everything.
class HdTideLightLinks {
public:
    void SetLight(std::string const& light, TfToken const& lightLink, TfToken const& shadowLink);
    void RemoveLight(std::string const& light);
    void SetCategories(std::string const& rprim, VtArray<TfToken> const& categories);
    /// An instanced rprim's per-instance categories (empty when no instance has any): its
    /// instance k is then a member as `rprim[k]`, the name the rprim's `instancePaths` gives
    /// it, when it or the rprim holds the light's token.
    void SetInstanceCategories(std::string const& rprim, std::vector<std::set<TfToken>> categories);
    void RemoveRprim(std::string const& rprim);
    /// Whether an rprim is instanced (its instancer's categories can change without it).
    void SetInstanced(std::string const& rprim, bool instanced);
    /// A light's collection changed (or a light came after the first commit): instances' categories
    /// are to be read again. UsdImaging's scene delegate (v24.08) marks gprims' categories dirty
    /// when a collection changes, but not native instances'.
    void RequestInstanceRefresh();
    /// The instanced rprims whose categories are to be read again (once per request); they
    /// stay pending until their next sync (`Refreshed`).
    std::vector<std::string> TakeInstanceRefresh();
    void Refreshed(std::string const& rprim);
    /// Whether a refresh is requested or awaits syncs: the render is not converged then.
    bool RefreshPending();
    /// Whether the collections were forwarded at least once (the first sync is over).
    bool Committed();
    /// Forwards the collections that changed since the last call.
    void Forward(tide::RenderParam& param);

private:
    struct Sent {
        bool everything = false;
        std::vector<std::string> includes;
        bool operator==(Sent const& o) const { return everything == o.everything && includes == o.includes; }
    };
    std::mutex _mutex;
    bool _changed = false;
    bool _refresh = false;
    bool _committed = false;
    std::set<std::string> _instanced;
    std::set<std::string> _pending;
    std::map<std::string, std::array<TfToken, 2>> _lights;
    std::map<std::string, std::set<TfToken>> _categories;
    std::map<std::string, std::vector<std::set<TfToken>>> _instanceCategories;
    /// (light, link) -> what was last forwarded.
    std::map<std::pair<std::string, int>, Sent> _sent;
};

/// What the Hd prims of one delegate share: the tide:: state, the light-link tables and the
/// lock that serialises reading VDB grids.
struct HdTideShared {
    tide::RenderParam* param = nullptr;
    HdTideLightLinks links;
    std::mutex vdbMutex;
    /// Each rprim's render tag as last forwarded: a tag the render index changes without a
    /// sync (the prim's new purpose untracked) is forwarded at the commit.
    std::mutex tagMutex;
    std::unordered_map<HdRprim const*, TfToken> forwardedTags;
};

class HdTideRenderDelegate final : public HdRenderDelegate {
public:
    HdTideRenderDelegate();
    explicit HdTideRenderDelegate(HdRenderSettingsMap const& settingsMap);
    ~HdTideRenderDelegate() override;

    HdRenderParam* GetRenderParam() const override { return nullptr; }
    TfTokenVector const& GetSupportedRprimTypes() const override;
    TfTokenVector const& GetSupportedSprimTypes() const override;
    TfTokenVector const& GetSupportedBprimTypes() const override;
    HdResourceRegistrySharedPtr GetResourceRegistry() const override;

    HdRenderPassSharedPtr CreateRenderPass(HdRenderIndex* index, HdRprimCollection const& collection) override;
    HdInstancer* CreateInstancer(HdSceneDelegate* delegate, SdfPath const& id) override;
    void DestroyInstancer(HdInstancer* instancer) override;

    HdRprim* CreateRprim(TfToken const& typeId, SdfPath const& rprimId) override;
    void DestroyRprim(HdRprim* rPrim) override;
    HdSprim* CreateSprim(TfToken const& typeId, SdfPath const& sprimId) override;
    HdSprim* CreateFallbackSprim(TfToken const& typeId) override;
    void DestroySprim(HdSprim* sPrim) override;
    HdBprim* CreateBprim(TfToken const& typeId, SdfPath const& bprimId) override;
    HdBprim* CreateFallbackBprim(TfToken const& typeId) override;
    void DestroyBprim(HdBprim* bPrim) override;

    void CommitResources(HdChangeTracker* tracker) override;
    TfToken GetMaterialBindingPurpose() const override { return HdTokens->full; }
    /// Material outputs in this order: Tide's own (`outputs:tide:surface`), MaterialX's
    /// (`outputs:mtlx:surface`: standard_surface and its nodes), the universal one.
    TfTokenVector GetMaterialRenderContexts() const override { return {TfToken("tide"), TfToken("mtlx"), TfToken()}; }
    HdAovDescriptor GetDefaultAovDescriptor(TfToken const& name) const override;

    /// TideRenderSettingsAPI's settings (tide:samples, tide:maxDepth, ...) with their defaults.
    HdRenderSettingDescriptorList GetRenderSettingDescriptors() const override;
    /// Stores the setting and forwards the settings to the delegate's renderSettings prim.
    void SetRenderSetting(TfToken const& key, VtValue const& value) override;
    /// The newest render pass's progress (`percentDone`), `tide:converged`, its summary
    /// (`tide:<key>` strings) and `tide:error` when it failed.
    VtDictionary GetRenderStats() const override;
    /// "tide": render settings prims hand their `tide:` attributes to the delegate.
    TfTokenVector GetRenderSettingsNamespaces() const override;

    /// Background rendering (a viewer's pause and stop): paused, the render waits where it is
    /// (buffers keep their pixels, edits are still taken) and resumes from the very sample it
    /// stopped at; stopped, it ends, reports itself converged, and executions start nothing
    /// until Restart renders the last one from its start.
    bool IsPauseSupported() const override { return true; }
    bool IsPaused() const override { return _tide->IsPaused(); }
    bool Pause() override { return _tide->Pause(); }
    bool Resume() override { return _tide->Resume(); }
    bool IsStopSupported() const override { return true; }
    bool IsStopped() const override { return _tide->IsStopped(); }
    bool Stop(bool blocking = true) override;
    bool Restart() override { return _tide->Restart(); }

    tide::RenderDelegate& Tide() { return *_tide; }
    /// Records whether the renderSettings bprim at `path` is the active one.
    void SetActiveSettings(std::string const& path, bool active);
    /// The settings prim a render pass uses: the active renderSettings bprim, else the one
    /// holding the HdRenderSettingsMap's settings.
    std::string SettingsPathForPass() const;
    /// Whether instanced rprims are still to read their light-link categories again.
    bool InstanceRefreshPending() const { return _shared->links.RefreshPending(); }

private:
    /// Forwards the settings map's Tide settings to the renderSettings prim.
    void _SyncSettings();

    std::unique_ptr<tide::RenderDelegate> _tide;
    HdResourceRegistrySharedPtr _registry;
    tide::Sprim* _settingsPrim = nullptr;
    tide::MemorySceneSource _settingsSource;
    std::weak_ptr<tide::RenderPass> _lastPass;
    std::unique_ptr<HdTideShared> _shared;
    mutable std::mutex _activeMutex;
    std::string _activeSettings;
};

PXR_NAMESPACE_CLOSE_SCOPE
