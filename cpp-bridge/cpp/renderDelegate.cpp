//! RenderDelegate, RenderPass and RenderIndex.
#include "tide/renderDelegate.h"
#include "tide/renderIndex.h"
#include "tide/renderParam.h"

#include <algorithm>
#include <exception>
#include <set>
#include <tuple>

namespace tide {

namespace {

rust::Str Str(const std::string& s) { return rust::Str(s.data(), s.size()); }

bool Contains(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// RenderDelegate

RenderDelegate::RenderDelegate() : _param(new RenderParam()) {}

RenderDelegate::RenderDelegate(const RenderSettingsMap& settings) : RenderDelegate() { _settings = settings; }

RenderDelegate::~RenderDelegate() = default;

const std::vector<std::string>& RenderDelegate::GetSupportedRprimTypes() const {
    static const std::vector<std::string> types = {"mesh", "basisCurves", "points", "sphere", "cube",
                                                   "cylinder", "cone", "capsule", "plane", "tideOcean",
                                                   "volume"};
    return types;
}

const std::vector<std::string>& RenderDelegate::GetSupportedSprimTypes() const {
    static const std::vector<std::string> types = {"camera", "material", "distantLight", "domeLight",
                                                   "sphereLight", "rectLight", "diskLight", "cylinderLight",
                                                   "portalLight", "renderSettings"};
    return types;
}

const std::vector<std::string>& RenderDelegate::GetSupportedBprimTypes() const {
    static const std::vector<std::string> types = {"renderBuffer"};
    return types;
}

int RenderDelegate::AovChannels(const std::string& name) { return int(rs::hydra_aov_channels(Str(name))); }

static bool CreateInRust(RenderParam& param, const std::string& typeId, const std::string& id) {
    try {
        return param.GetDelegate().create_prim(Str(typeId), Str(id));
    } catch (const std::exception& e) {
        param.AddProblem(id, "", e.what());
        return false;
    }
}

Rprim* RenderDelegate::CreateRprim(const std::string& typeId, const std::string& rprimId) {
    if (!Contains(GetSupportedRprimTypes(), typeId)) {
        _param->AddProblem(rprimId, "", "unsupported rprim type '" + typeId + "'");
        return nullptr;
    }
    if (!CreateInRust(*_param, typeId, rprimId)) return nullptr;
    RenderParam* p = _param.get();
    if (typeId == "mesh" || typeId == "tideOcean" || typeId == "volume") return new Mesh(rprimId, typeId, p);
    if (typeId == "basisCurves") return new BasisCurves(rprimId, typeId, p);
    if (typeId == "points") return new Points(rprimId, typeId, p);
    return new ImplicitGprim(rprimId, typeId, p);
}

void RenderDelegate::DestroyRprim(Rprim* rprim) {
    if (!rprim) return;
    rprim->Finalize();
    delete rprim;
}

Sprim* RenderDelegate::CreateSprim(const std::string& typeId, const std::string& sprimId) {
    if (!Contains(GetSupportedSprimTypes(), typeId)) {
        _param->AddProblem(sprimId, "", "unsupported sprim type '" + typeId + "'");
        return nullptr;
    }
    if (!CreateInRust(*_param, typeId, sprimId)) return nullptr;
    RenderParam* p = _param.get();
    if (typeId == "material") return new Material(sprimId, typeId, p);
    if (typeId == "camera") return new Camera(sprimId, typeId, p);
    if (typeId == "renderSettings") return new RenderSettings(sprimId, typeId, p);
    return new Light(sprimId, typeId, p);
}

void RenderDelegate::DestroySprim(Sprim* sprim) {
    if (!sprim) return;
    sprim->Finalize();
    delete sprim;
}

Bprim* RenderDelegate::CreateBprim(const std::string& typeId, const std::string& bprimId) {
    if (!Contains(GetSupportedBprimTypes(), typeId)) {
        _param->AddProblem(bprimId, "", "unsupported bprim type '" + typeId + "'");
        return nullptr;
    }
    if (!CreateInRust(*_param, typeId, bprimId)) return nullptr;
    return new RenderBuffer(bprimId, _param.get());
}

void RenderDelegate::DestroyBprim(Bprim* bprim) {
    if (!bprim) return;
    bprim->Finalize();
    delete bprim;
}

void RenderDelegate::CommitResources() {
    _PendRows(false);
}

void RenderDelegate::CheckRender() {
    _PendRows(true);
}

void RenderDelegate::_PendRows(bool check) {
    try {
        rs::Delegate const& d = _param->GetDelegate();
        rust::Vec<rs::ProblemRow> rows = check ? d.check_render() : d.commit_resources();
        for (const auto& r : rows)
            _pending.push_back(Problem{std::string(r.prim), std::string(r.attribute), std::string(r.message)});
    } catch (const std::exception& e) {
        _param->AddProblem("", "", e.what());
    }
}

std::vector<Problem> RenderDelegate::TakeProblems() {
    // A prim synced again is checked again: what it reported before and no longer has is
    // forgotten, so a problem mended and brought back is reported again (one it still has is
    // found again and not repeated).
    std::set<std::string> synced = _param->TakeSynced();
    try {
        for (const auto& s : _param->GetDelegate().last_synced()) synced.emplace(std::string(s));
    } catch (const std::exception&) {
    }
    std::vector<Problem> fresh = _param->TakeProblems();
    // what this batch has, looked up once per reported entry
    std::set<std::tuple<std::string, std::string, std::string>> found;
    std::set<std::pair<std::string, std::string>> foundWhere;
    for (const auto* batch : {&_pending, &fresh})
        for (const Problem& p : *batch) {
            found.emplace(p.prim, p.attribute, p.message);
            foundWhere.emplace(p.prim, p.attribute);
        }
    for (auto it = _reported.begin(); it != _reported.end();)
        it = synced.count(std::get<0>(*it)) && !found.count(*it) ? _reported.erase(it) : std::next(it);
    for (auto it = _reportedByRust.begin(); it != _reportedByRust.end();)
        it = synced.count(it->first) && !foundWhere.count(*it) ? _reportedByRust.erase(it) : std::next(it);
    // The delegate's problems come first; a C++ problem about the same prim and attribute
    // (e.g. a texture the delegate also reports) is not repeated.
    std::vector<Problem> candidates = std::exchange(_pending, {});
    for (const auto& p : candidates) _reportedByRust.emplace(p.prim, p.attribute);
    for (auto& p : fresh)
        if (!_reportedByRust.count({p.prim, p.attribute})) candidates.push_back(std::move(p));
    std::vector<Problem> out;
    for (auto& p : candidates)
        if (_reported.emplace(p.prim, p.attribute, p.message).second) out.push_back(std::move(p));
    return out;
}

std::vector<std::string> RenderDelegate::GetLastSynced() const {
    std::vector<std::string> out;
    try {
        for (const auto& s : _param->GetDelegate().last_synced()) out.emplace_back(std::string(s));
    } catch (const std::exception& e) {
        _param->AddProblem("", "", e.what());
    }
    return out;
}

std::shared_ptr<RenderPass> RenderDelegate::CreateRenderPass() { return std::make_shared<RenderPass>(_param.get()); }

namespace {

/// Runs one of the Rust delegate's render controls; false with a problem where it failed.
template <typename F>
bool Control(RenderParam& param, const char* what, F&& f) {
    try {
        f(param.GetDelegate());
        return true;
    } catch (const std::exception& e) {
        param.AddProblem("", "", std::string(what) + ": " + e.what());
        return false;
    }
}

}  // namespace

bool RenderDelegate::Pause() { return Control(*_param, "pause", [](auto& d) { d.pause_render(); }); }

bool RenderDelegate::Resume() { return Control(*_param, "resume", [](auto& d) { d.resume_render(); }); }

bool RenderDelegate::Stop(bool blocking) {
    bool stopped = false;
    return Control(*_param, "stop", [&](auto& d) { stopped = d.stop_render(blocking); }) && stopped;
}

bool RenderDelegate::Restart() { return Control(*_param, "restart", [](auto& d) { d.restart_render(); }); }

bool RenderDelegate::IsPaused() const {
    bool paused = false;
    Control(*_param, "paused", [&](auto& d) { paused = d.render_paused(); });
    return paused;
}

bool RenderDelegate::IsStopped() const {
    bool stopped = false;
    Control(*_param, "stopped", [&](auto& d) { stopped = d.render_stopped(); });
    return stopped;
}

void RenderDelegate::SetRenderSetting(const std::string& key, const Value& value) { _settings[key] = value; }

Value RenderDelegate::GetRenderSetting(const std::string& key) const {
    auto it = _settings.find(key);
    return it == _settings.end() ? Value{} : it->second;
}

// ---------------------------------------------------------------------------------------------
// RenderPass

RenderPass::RenderPass(RenderParam* param) : _param(param), _pass(param->GetDelegate().create_render_pass()) {}

// The Rust pass, dropped with this one, cancels the render only if it is the pass that
// started it: a pass replaced by a newer one (a viewport's next frame) must not stop that
// one's render.
RenderPass::~RenderPass() = default;

bool RenderPass::Execute(const RenderPassState& state, std::string* error) {
    rust::Vec<rs::AovBinding> bindings;
    _bufferIds.clear();
    for (const auto& b : state.aovBindings) {
        rust::Vec<double> clear;
        for (double v : b.clearValue) clear.push_back(v);
        bindings.push_back(rs::AovBinding{rust::String(b.aovName), rust::String(b.renderBufferId), std::move(clear)});
        if (b.renderBuffer) {
            // live now (the caller's binding); later only through the RenderParam's registry
            b.renderBuffer->SetConverged(false);
            _bufferIds.push_back(b.renderBuffer->GetId());
        }
    }
    rust::Vec<rust::String> tags;
    for (const auto& t : state.renderTags) tags.push_back(rust::String(t));
    try {
        _pass->execute(Str(state.camera), bindings, Str(state.renderSettings), state.hydra,
                       rust::Slice<const double>(state.projection.data(), state.projection.size()), tags);
        return true;
    } catch (const std::exception& e) {
        if (error) *error = e.what();
        return false;
    }
}

bool RenderPass::IsConverged() const {
    bool converged = false;
    try {
        converged = _pass->is_converged();
    } catch (const std::exception&) {
        return false;
    }
    _param->SetBuffersConverged(_bufferIds, converged);
    return converged;
}

std::vector<std::string> RenderPass::GetSummary() const {
    std::vector<std::string> out;
    try {
        for (const auto& s : _pass->summary()) out.emplace_back(std::string(s));
    } catch (const std::exception&) {
    }
    return out;
}

double RenderPass::GetProgress() const {
    try {
        return _pass->progress();
    } catch (const std::exception&) {
        return 0.0;
    }
}

bool RenderPass::Wait(double timeoutS) const {
    try {
        return _pass->wait(timeoutS);
    } catch (const std::exception&) {
        return true;
    }
}

void RenderPass::Cancel() {
    try {
        _pass->cancel();
    } catch (const std::exception&) {
    }
}

std::string RenderPass::GetError() const {
    try {
        return std::string(_pass->error());
    } catch (const std::exception& e) {
        return e.what();
    }
}

// ---------------------------------------------------------------------------------------------
// RenderIndex

RenderIndex::RenderIndex(RenderDelegate* delegate, SceneSource* source) : _delegate(delegate), _source(source) {}

RenderIndex::~RenderIndex() {
    for (auto& kv : _prims) _Destroy(kv.second);
    _prims.clear();
}

void RenderIndex::_Destroy(const Entry& e) {
    switch (e.kind) {
    case Kind::R: _delegate->DestroyRprim(static_cast<Rprim*>(e.prim)); break;
    case Kind::S: _delegate->DestroySprim(static_cast<Sprim*>(e.prim)); break;
    case Kind::B: _delegate->DestroyBprim(static_cast<Bprim*>(e.prim)); break;
    }
}

bool RenderIndex::InsertPrim(const std::string& typeId, const std::string& path) {
    RemovePrim(path);
    Entry e{Kind::R, nullptr};
    if (Contains(_delegate->GetSupportedSprimTypes(), typeId)) {
        e = Entry{Kind::S, _delegate->CreateSprim(typeId, path)};
    } else if (Contains(_delegate->GetSupportedBprimTypes(), typeId)) {
        e = Entry{Kind::B, _delegate->CreateBprim(typeId, path)};
    } else {
        // Unknown types go here too: the delegate records the problem.
        e = Entry{Kind::R, _delegate->CreateRprim(typeId, path)};
    }
    if (!e.prim) return false;
    _prims[path] = e;
    _tracker.MarkDirty(path, e.prim->GetInitialDirtyBitsMask());
    return true;
}

bool RenderIndex::RemovePrim(const std::string& path) {
    auto it = _prims.find(path);
    if (it == _prims.end()) return false;
    Entry e = it->second;
    _prims.erase(it);
    _tracker.Forget(path);
    _Destroy(e);
    return true;
}

bool RenderIndex::HasPrim(const std::string& path) const { return _prims.count(path) != 0; }

std::string RenderIndex::GetPrimType(const std::string& path) const {
    auto it = _prims.find(path);
    return it == _prims.end() ? std::string() : it->second.prim->GetTypeId();
}

void RenderIndex::MarkAttributeDirty(const std::string& path, const std::string& key) {
    auto it = _prims.find(path);
    if (it == _prims.end()) return;
    _tracker.MarkDirty(path, ChangeTracker::BitsForKey(it->second.prim->GetTypeId(), key));
}

void RenderIndex::MarkPrimvarDirty(const std::string& path) {
    if (_prims.count(path)) _tracker.MarkDirty(path, ChangeTracker::DirtyPrimvar);
}

void RenderIndex::SyncAll() {
    const std::vector<std::string> dirty = _tracker.DirtyPaths();
    for (Kind pass : {Kind::B, Kind::S, Kind::R}) {
        for (const std::string& path : dirty) {
            auto it = _prims.find(path);
            if (it == _prims.end() || it->second.kind != pass) continue;
            DirtyBits bits = _tracker.GetDirtyBits(path);
            it->second.prim->Sync(*_source, &bits);
            _tracker.MarkClean(path);
        }
    }
    _delegate->CommitResources();
}

RenderBuffer* RenderIndex::GetRenderBuffer(const std::string& path) const {
    auto it = _prims.find(path);
    if (it == _prims.end() || it->second.kind != Kind::B) return nullptr;
    return static_cast<RenderBuffer*>(it->second.prim);
}

}  // namespace tide
