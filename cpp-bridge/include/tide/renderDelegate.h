//! tide::RenderDelegate: shaped like HdRenderDelegate: creates and destroys prims by type
//! and path, commits synced data, creates render passes, holds render settings.
#pragma once

#include "prims.h"
#include "renderBuffer.h"
#include "renderPass.h"
#include "value.h"

#include <map>
#include <memory>
#include <set>
#include <tuple>
#include <string>
#include <vector>

namespace tide {

class RenderParam;

using RenderSettingsMap = std::map<std::string, Value>;

class RenderDelegate {
public:
    RenderDelegate();
    explicit RenderDelegate(const RenderSettingsMap& settings);
    ~RenderDelegate();
    RenderDelegate(const RenderDelegate&) = delete;
    RenderDelegate& operator=(const RenderDelegate&) = delete;

    RenderParam* GetRenderParam() const { return _param.get(); }

    const std::vector<std::string>& GetSupportedRprimTypes() const;
    const std::vector<std::string>& GetSupportedSprimTypes() const;
    const std::vector<std::string>& GetSupportedBprimTypes() const;
    /// Channels of a Hydra AOV (an HdAovTokens name or a Tide `sourceName`) as Tide renders it;
    /// 0 for one it does not render.
    static int AovChannels(const std::string& name);

    /// A new prim (owned by the caller until Destroy*), or nullptr for an unknown type (a
    /// problem is recorded).
    Rprim* CreateRprim(const std::string& typeId, const std::string& rprimId);
    void DestroyRprim(Rprim* rprim);
    Sprim* CreateSprim(const std::string& typeId, const std::string& sprimId);
    void DestroySprim(Sprim* sprim);
    Bprim* CreateBprim(const std::string& typeId, const std::string& bprimId);
    void DestroyBprim(Bprim* bprim);

    /// Converts what was synced since the last commit into the core scene.
    void CommitResources();
    /// Commits, then prepares the scene as a render of the active camera and settings would
    /// (the renderer's validation and world build) without rendering; what both find goes
    /// to TakeProblems.
    void CheckRender();
    /// Problems found by the last commits (C++ and Rust), each reported once.
    std::vector<Problem> TakeProblems();
    /// Prims synced by the last commit.
    std::vector<std::string> GetLastSynced() const;

    std::shared_ptr<RenderPass> CreateRenderPass();

    /// Background rendering, as HdRenderDelegate's: Pause holds the render where it is (the
    /// buffers keep their pixels) until Resume goes on from there; Stop ends it and leaves
    /// executions idle until Restart renders the last one asked for. Each returns whether it
    /// was carried out (a problem says why not). Nothing is published once Stop returns; a
    /// blocking Stop also returns only when no worker renders (a scene being prepared is
    /// finished first).
    bool Pause();
    bool Resume();
    bool IsPaused() const;
    bool Stop(bool blocking = true);
    bool Restart();
    bool IsStopped() const;

    void SetRenderSetting(const std::string& key, const Value& value);
    Value GetRenderSetting(const std::string& key) const;
    const RenderSettingsMap& GetRenderSettings() const { return _settings; }

private:
    /// Adds the rows of the Rust delegate's commit (or, with `check`, of its check) to
    /// `_pending`.
    void _PendRows(bool check);

    std::unique_ptr<RenderParam> _param;
    RenderSettingsMap _settings;
    std::vector<Problem> _pending;
    /// (prim, attribute, message) already reported: each problem is reported once.
    std::set<std::tuple<std::string, std::string, std::string>> _reported;
    /// (prim, attribute) the Rust delegate reported on: the C++ layer does not repeat them.
    std::set<std::pair<std::string, std::string>> _reportedByRust;
};

}  // namespace tide
