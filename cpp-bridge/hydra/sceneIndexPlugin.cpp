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
//!   indices carried no light linking: every light reached everything.
//! - HdTideInstanceCategoriesPlugin appends HdTideInstanceCategoriesSceneIndex after it: OpenUSD
//!   v24.08's HdsiLightLinkingSceneIndex gives instanced prims no categories (its instancer data
//!   source leaves `instanceCategories` out), so a linked light missed every native instance.
//!   This filter gives each instancer the categories of its instances: for each instance
//!   location (HdInstancerTopologySchema's `instanceLocations`, the instance prims' paths), the
//!   category ids the lights carry (`light.lightLink`, `light.shadowLink`, as HdsiLightLinking
//!   SceneIndex set them) whose collection's membership expression matches it, as
//!   UsdImaging's scene delegate answers GetInstanceCategories.
#include "pxr/imaging/hd/categoriesSchema.h"
#include "pxr/imaging/hd/collectionExpressionEvaluator.h"
#include "pxr/imaging/hd/collectionPredicateLibrary.h"
#include "pxr/imaging/hd/collectionSchema.h"
#include "pxr/imaging/hd/collectionsSchema.h"
#include "pxr/imaging/hd/filteringSceneIndex.h"
#include "pxr/imaging/hd/instanceCategoriesSchema.h"
#include "pxr/imaging/hd/instancerTopologySchema.h"
#include "pxr/imaging/hd/lightSchema.h"
#include "pxr/imaging/hd/overlayContainerDataSource.h"
#include "pxr/imaging/hd/retainedDataSource.h"
#include "pxr/imaging/hd/sceneIndexPrimView.h"
#include "pxr/imaging/hd/tokens.h"
#include "pxr/imaging/hd/sceneIndexPlugin.h"
#include "pxr/imaging/hd/sceneIndexPluginRegistry.h"
#include "pxr/imaging/hdsi/lightLinkingSceneIndex.h"
#include "pxr/imaging/hdsi/renderSettingsFilteringSceneIndex.h"
#include "pxr/pxr.h"

#include <mutex>
#include <set>
#include <utility>
#include <vector>

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

TF_DECLARE_REF_PTRS(HdTideInstanceCategoriesSceneIndex);

/// Gives instancers the light-link categories of their instances (see the file's comment).
class HdTideInstanceCategoriesSceneIndex final : public HdSingleInputFilteringSceneIndexBase {
public:
    static HdTideInstanceCategoriesSceneIndexRefPtr New(HdSceneIndexBaseRefPtr const& input) {
        return TfCreateRefPtr(new HdTideInstanceCategoriesSceneIndex(input));
    }

    HdSceneIndexPrim GetPrim(SdfPath const& path) const override {
        HdSceneIndexPrim prim = _GetInputSceneIndex()->GetPrim(path);
        if (prim.dataSource && prim.primType == HdPrimTypeTokens->instancer) {
            if (HdContainerDataSourceHandle cats = _InstanceCategories(prim.dataSource)) {
                prim.dataSource = HdOverlayContainerDataSource::New(
                    HdRetainedContainerDataSource::New(HdInstanceCategoriesSchemaTokens->instanceCategories, cats),
                    prim.dataSource);
            }
        }
        return prim;
    }

    SdfPathVector GetChildPrimPaths(SdfPath const& path) const override {
        return _GetInputSceneIndex()->GetChildPrimPaths(path);
    }

protected:
    // Instancers' categories change only when a light with a link (a non-empty lightLink or
    // shadowLink id) comes, goes or changes: lights that reach everything dirty nothing.
    void _PrimsAdded(HdSceneIndexBase const&, HdSceneIndexObserver::AddedPrimEntries const& entries) override {
        bool changed = false;
        {
            std::lock_guard<std::mutex> lock(_mutex);
            for (auto const& e : entries) {
                // a prim added again may have changed type
                _lights.erase(e.primPath);
                _instancers.erase(e.primPath);
                if (HdPrimTypeIsLight(e.primType)) {
                    _lights.insert(e.primPath);
                    changed |= _Relink(e.primPath);
                } else {
                    changed |= _linked.erase(e.primPath) > 0;
                    if (e.primType == HdPrimTypeTokens->instancer) _instancers.insert(e.primPath);
                }
            }
            if (changed) _stale = true;
        }
        _SendPrimsAdded(entries);
        if (changed) _DirtyInstancers({});
    }

    void _PrimsRemoved(HdSceneIndexBase const&, HdSceneIndexObserver::RemovedPrimEntries const& entries) override {
        bool changed = false;
        {
            std::lock_guard<std::mutex> lock(_mutex);
            for (auto const& e : entries) {
                _EraseUnder(_lights, e.primPath);
                changed |= _EraseUnder(_linked, e.primPath);
                _EraseUnder(_instancers, e.primPath);
            }
            if (changed) _stale = true;
        }
        _SendPrimsRemoved(entries);
        if (changed) _DirtyInstancers({});
    }

    void _PrimsDirtied(HdSceneIndexBase const&, HdSceneIndexObserver::DirtiedPrimEntries const& entries) override {
        static HdDataSourceLocatorSet const linkLocators{HdLightSchema::GetDefaultLocator(), HdCollectionsSchema::GetDefaultLocator()};
        bool changed = false;
        HdSceneIndexObserver::DirtiedPrimEntries extra;
        {
            std::lock_guard<std::mutex> lock(_mutex);
            for (auto const& e : entries) {
                if (_lights.count(e.primPath) && e.dirtyLocators.Intersects(linkLocators)) {
                    changed |= _Relink(e.primPath);
                } else if (_instancers.count(e.primPath) && e.dirtyLocators.Intersects(HdInstancerTopologySchema::GetDefaultLocator())) {
                    // other instances, other categories
                    extra.emplace_back(e.primPath, HdInstanceCategoriesSchema::GetDefaultLocator());
                }
            }
            if (changed) _stale = true;
        }
        _SendPrimsDirtied(entries);
        if (changed) {
            _DirtyInstancers(std::move(extra));
        } else if (!extra.empty()) {
            _SendPrimsDirtied(extra);
        }
    }

private:
    explicit HdTideInstanceCategoriesSceneIndex(HdSceneIndexBaseRefPtr const& input)
        : HdSingleInputFilteringSceneIndexBase(input) {
        // what the input already holds (it may have been populated before this filter)
        for (SdfPath const& path : HdSceneIndexPrimView(input)) {
            TfToken const type = input->GetPrim(path).primType;
            if (HdPrimTypeIsLight(type)) {
                _lights.insert(path);
                _Relink(path);
            } else if (type == HdPrimTypeTokens->instancer) {
                _instancers.insert(path);
            }
        }
    }

    /// The id the light-linking scene index gave a light's `name` collection (empty: the light
    /// reaches everything).
    static TfToken _LinkId(HdContainerDataSourceHandle const& light, TfToken const& name) {
        auto const id = light ? HdTypedSampledDataSource<TfToken>::Cast(light->Get(name)) : nullptr;
        return id ? id->GetTypedValue(0.0f) : TfToken();
    }

    /// Whether the light at `path` has a lightLink or shadowLink id.
    bool _IsLinked(SdfPath const& path) const {
        HdContainerDataSourceHandle const light =
            HdLightSchema::GetFromParent(_GetInputSceneIndex()->GetPrim(path).dataSource).GetContainer();
        return !_LinkId(light, HdTokens->lightLink).IsEmpty() || !_LinkId(light, HdTokens->shadowLink).IsEmpty();
    }

    /// Reads again whether the light at `path` has a link; returns whether it had or has one
    /// (its id or its membership may then have changed instances' categories).
    bool _Relink(SdfPath const& path) {
        const bool had = _linked.erase(path) > 0;
        if (!_IsLinked(path)) return had;
        _linked.insert(path);
        return true;
    }

    static bool _EraseUnder(std::set<SdfPath>& paths, SdfPath const& root) {
        auto it = paths.lower_bound(root);
        bool any = false;
        while (it != paths.end() && it->HasPrefix(root)) {
            it = paths.erase(it);
            any = true;
        }
        return any;
    }

    /// Every instancer's categories changed (a light's link did). Hydra's emulation turns no
    /// instancer locator of categories into a dirty bit, so the prims of its prototypes are
    /// dirtied too (their `categories`: a render delegate's rprims then read them again, with
    /// their instancer's).
    void _DirtyInstancers(HdSceneIndexObserver::DirtiedPrimEntries entries) {
        std::vector<SdfPath> instancers;
        {
            std::lock_guard<std::mutex> lock(_mutex);
            instancers.assign(_instancers.begin(), _instancers.end());
        }
        HdSceneIndexBaseRefPtr const& input = _GetInputSceneIndex();
        for (SdfPath const& p : instancers) {
            entries.emplace_back(p, HdInstanceCategoriesSchema::GetDefaultLocator());
            HdContainerDataSourceHandle const ds = input->GetPrim(p).dataSource;
            HdPathArrayDataSourceHandle const protos = HdInstancerTopologySchema::GetFromParent(ds).GetPrototypes();
            if (!protos) continue;
            for (SdfPath const& root : protos->GetTypedValue(0.0f))
                for (SdfPath const& q : HdSceneIndexPrimView(input, root))
                    entries.emplace_back(q, HdCategoriesSchema::GetDefaultLocator());
        }
        if (!entries.empty()) _SendPrimsDirtied(entries);
    }

    using _Links = std::vector<std::pair<TfToken, HdCollectionExpressionEvaluator>>;

    /// (category id, membership) of every light's lightLink and shadowLink collection that
    /// the light-linking scene index gave an id (trivial collections have none).
    std::shared_ptr<_Links const> _CurrentLinks() const {
        std::lock_guard<std::mutex> lock(_mutex);
        if (!_stale && _links) return _links;
        auto links = std::make_shared<_Links>();
        std::set<TfToken> seen;
        for (SdfPath const& path : _linked) {
            HdContainerDataSourceHandle const ds = _GetInputSceneIndex()->GetPrim(path).dataSource;
            HdContainerDataSourceHandle const light = HdLightSchema::GetFromParent(ds).GetContainer();
            HdCollectionsSchema const collections = HdCollectionsSchema::GetFromParent(ds);
            if (!light || !collections) continue;
            for (TfToken const& name : {HdTokens->lightLink, HdTokens->shadowLink}) {
                TfToken const id = _LinkId(light, name);
                if (id.IsEmpty() || !seen.insert(id).second) continue;
                HdPathExpressionDataSourceHandle const expr = collections.GetCollection(name).GetMembershipExpression();
                if (!expr) continue;
                links->emplace_back(id, HdCollectionExpressionEvaluator(_GetInputSceneIndex(), expr->GetTypedValue(0.0f),
                                                                        HdGetCollectionPredicateLibrary()));
            }
        }
        _links = links;
        _stale = false;
        return _links;
    }

    HdContainerDataSourceHandle _InstanceCategories(HdContainerDataSourceHandle const& instancer) const {
        HdPathArrayDataSourceHandle const locationsDs = HdInstancerTopologySchema::GetFromParent(instancer).GetInstanceLocations();
        if (!locationsDs) return nullptr;
        VtArray<SdfPath> const locations = locationsDs->GetTypedValue(0.0f);
        std::shared_ptr<_Links const> const links = _CurrentLinks();
        std::vector<HdDataSourceBaseHandle> values;
        values.reserve(locations.size());
        TfTokenVector included;
        for (SdfPath const& location : locations) {
            included.clear();
            for (auto const& [id, eval] : *links) {
                if (eval.Match(location)) included.push_back(id);
            }
            values.push_back(HdCategoriesSchema::BuildRetained(included.size(), included.data(), 0, nullptr));
        }
        return HdInstanceCategoriesSchema::BuildRetained(HdRetainedSmallVectorDataSource::New(values.size(), values.data()));
    }

    mutable std::mutex _mutex;
    std::set<SdfPath> _lights;
    /// The lights with a lightLink or shadowLink id.
    std::set<SdfPath> _linked;
    std::set<SdfPath> _instancers;
    mutable bool _stale = true;
    mutable std::shared_ptr<_Links const> _links;
};

class HdTideInstanceCategoriesPlugin final : public HdSceneIndexPlugin {
protected:
    HdSceneIndexBaseRefPtr _AppendSceneIndex(HdSceneIndexBaseRefPtr const& inputScene,
                                             HdContainerDataSourceHandle const&) override {
        return HdTideInstanceCategoriesSceneIndex::New(inputScene);
    }
};

TF_REGISTRY_FUNCTION(TfType) {
    HdSceneIndexPluginRegistry::Define<HdTideRenderSettingsFilterPlugin>();
    HdSceneIndexPluginRegistry::Define<HdTideLightLinkingPlugin>();
    HdSceneIndexPluginRegistry::Define<HdTideInstanceCategoriesPlugin>();
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
    // right after it (same phase, appended at its end)
    HdSceneIndexPluginRegistry::GetInstance().RegisterSceneIndexForRenderer(
        "Tide", TfToken("HdTideInstanceCategoriesPlugin"), nullptr, /* insertionPhase = */ 4,
        HdSceneIndexPluginRegistry::InsertionOrderAtEnd);
}

PXR_NAMESPACE_CLOSE_SCOPE
