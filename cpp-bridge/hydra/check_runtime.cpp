//! check_runtime: loads HdTideRendererPlugin through Hydra's renderer-plugin registry and renders
//! a scene handed to it by a small in-memory HdSceneDelegate (a sphere mesh of the default
//! material inside a uniform white dome, a camera looking at it), with Hydra's own HdRenderIndex,
//! HdEngine, render pass state and a renderBuffer bprim, then checks the image: the dome seen
//! directly reads its radiance 1 and the sphere (default grey, albedo 0.18, in a white furnace)
//! reads 0.18; then the sphere moves out of view (its transform marked dirty in Hydra's change
//! tracker) and the pass, restarted, sees the dome there. Built with TIDE_CHECK_USD_IMAGING and run
//! as `check_runtime STAGE CAMERA W H SPP MODE`, it renders a USD stage through UsdImaging instead
//! and prints the image's mean RGB with standard errors. MODE `delegate` uses UsdImaging's scene
//! delegate (UsdImagingDelegate, what usdview uses by default in v24.08), `sceneIndex` its scene
//! indices (UsdImagingStageSceneIndex and the filters UsdImagingCreateSceneIndices adds, what
//! usdview uses with USDIMAGINGGL_ENGINE_ENABLE_SCENE_INDEX=1), inserted into the render index,
//! which hands them to the plugin through its scene-index emulation. Not part of CI: it needs an
//! OpenUSD build with imaging (see check_runtime.sh).
#include "pxr/base/gf/camera.h"
#include "pxr/base/gf/matrix4d.h"
#include "pxr/base/gf/range1f.h"
#include "pxr/base/gf/vec3f.h"
#include "pxr/base/plug/registry.h"
#include "pxr/base/tf/diagnostic.h"
#include "pxr/imaging/hd/camera.h"
#include "pxr/imaging/hd/engine.h"
#include "pxr/imaging/hd/light.h"
#include "pxr/imaging/hd/meshTopology.h"
#include "pxr/imaging/hd/pluginRenderDelegateUniqueHandle.h"
#include "pxr/imaging/hd/renderBuffer.h"
#include "pxr/imaging/hd/renderDelegate.h"
#include "pxr/imaging/hd/renderIndex.h"
#include "pxr/imaging/hd/renderPass.h"
#include "pxr/imaging/hd/renderPassState.h"
#include "pxr/imaging/hd/rendererPluginRegistry.h"
#include "pxr/imaging/hd/rprimCollection.h"
#include "pxr/imaging/hd/sceneDelegate.h"
#include "pxr/imaging/hd/task.h"
#include "pxr/imaging/hd/tokens.h"
#include "pxr/imaging/pxOsd/tokens.h"
#ifdef TIDE_CHECK_USD_IMAGING
#include "pxr/usd/usd/relationship.h"
#include "pxr/usd/usd/stage.h"
#include "pxr/usdImaging/usdImaging/delegate.h"
#include "pxr/imaging/hd/sceneIndexPluginRegistry.h"
#include "pxr/imaging/hdsi/legacyDisplayStyleOverrideSceneIndex.h"
#include "pxr/imaging/hdsi/sceneGlobalsSceneIndex.h"
#include "pxr/usdImaging/usdImaging/sceneIndices.h"
#include "pxr/usdImaging/usdImaging/stageSceneIndex.h"
#endif

#include <algorithm>
#include <map>
#include <chrono>
#include <cstdlib>
#include <tuple>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>

PXR_NAMESPACE_USING_DIRECTIVE

namespace {

const SdfPath kSphere("/Sphere");
const SdfPath kCamera("/Camera");
const SdfPath kDome("/Dome");
const SdfPath kBuffer("/Buffers/color");
constexpr int kSize = 32;

/// The scene: a unit UV sphere at the origin, a camera 4 units away on +Z (40 mm lens on a
/// 36 mm back, so the sphere fills the middle of the frame), a dome of radiance 1.
class Scene final : public HdSceneDelegate {
public:
    explicit Scene(HdRenderIndex* index) : HdSceneDelegate(index, SdfPath::AbsoluteRootPath()) {
        const int n = 24;
        for (int i = 0; i <= n; ++i) {
            const double th = M_PI * i / n;
            for (int j = 0; j < 2 * n; ++j) {
                const double ph = M_PI * j / n;
                _points.push_back(GfVec3f(float(std::sin(th) * std::cos(ph)), float(std::cos(th)), float(std::sin(th) * std::sin(ph))));
            }
        }
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < 2 * n; ++j) {
                const int a = i * 2 * n + j, b = i * 2 * n + (j + 1) % (2 * n);
                _counts.push_back(4);
                // counter-clockwise seen from outside
                _indices.push_back(a);
                _indices.push_back(b);
                _indices.push_back(b + 2 * n);
                _indices.push_back(a + 2 * n);
            }
        }
    }
    HdMeshTopology GetMeshTopology(SdfPath const&) override {
        return HdMeshTopology(PxOsdOpenSubdivTokens->none, HdTokens->rightHanded, _counts, _indices);
    }
    GfMatrix4d GetTransform(SdfPath const& id) override {
        GfMatrix4d m(1.0);
        if (id == kCamera) m.SetTranslate(GfVec3d(0, 0, 4));
        if (id == kSphere) m.SetTranslate(sphereAt);
        return m;
    }
    /// Where the sphere is (moved by the edit step).
    GfVec3d sphereAt{0, 0, 0};
    bool GetVisible(SdfPath const&) override { return true; }
    VtValue Get(SdfPath const& id, TfToken const& key) override {
        if (id == kSphere && key == HdTokens->points) return VtValue(_points);
        return VtValue();
    }
    HdPrimvarDescriptorVector GetPrimvarDescriptors(SdfPath const& id, HdInterpolation interp) override {
        HdPrimvarDescriptorVector v;
        if (id == kSphere && interp == HdInterpolationVertex) v.emplace_back(HdTokens->points, interp, HdPrimvarRoleTokens->point);
        return v;
    }
    SdfPath GetMaterialId(SdfPath const&) override { return SdfPath(); }
    TfToken GetRenderTag(SdfPath const&) override { return HdRenderTagTokens->geometry; }
    VtValue GetCameraParamValue(SdfPath const&, TfToken const& key) override {
        if (key == HdCameraTokens->focalLength) return VtValue(40.0f * float(GfCamera::FOCAL_LENGTH_UNIT));
        if (key == HdCameraTokens->horizontalAperture || key == HdCameraTokens->verticalAperture)
            return VtValue(36.0f * float(GfCamera::APERTURE_UNIT));
        if (key == HdCameraTokens->horizontalApertureOffset || key == HdCameraTokens->verticalApertureOffset) return VtValue(0.0f);
        if (key == HdCameraTokens->projection) return VtValue(HdCamera::Perspective);
        if (key == HdCameraTokens->clippingRange) return VtValue(GfRange1f(0.01f, 1000.0f));
        return VtValue();
    }
    VtValue GetLightParamValue(SdfPath const&, TfToken const& key) override {
        if (key == HdLightTokens->intensity) return VtValue(1.0f);
        if (key == HdLightTokens->exposure) return VtValue(0.0f);
        if (key == HdLightTokens->color) return VtValue(GfVec3f(1, 1, 1));
        return VtValue();
    }
    HdRenderBufferDescriptor GetRenderBufferDescriptor(SdfPath const&) override {
        return HdRenderBufferDescriptor(GfVec3i(kSize, kSize, 1), HdFormatFloat32Vec4, false);
    }

private:
    VtVec3fArray _points;
    VtIntArray _counts, _indices;
};

/// The render tags of the render task: TIDE_CHECK_TAGS="SYNCED;EXECUTED" (comma-separated
/// lists: the tags whose rprims Hydra syncs, and those the pass is executed with, as a viewer
/// that has shown a purpose and then hides it), else `geometry` for both.
TfTokenVector CheckTags(bool executed) {
    std::string spec = std::getenv("TIDE_CHECK_TAGS") ? std::getenv("TIDE_CHECK_TAGS") : "geometry;geometry";
    const size_t semi = spec.find(';');
    std::string list = semi == std::string::npos ? spec : executed ? spec.substr(semi + 1) : spec.substr(0, semi);
    TfTokenVector tags;
    for (size_t at = 0; at <= list.size();) {
        const size_t comma = std::min(list.find(',', at), list.size());
        if (comma > at) tags.emplace_back(list.substr(at, comma - at));
        at = comma + 1;
    }
    return tags;
}

/// Syncs and executes one render pass.
class RenderTask final : public HdTask {
public:
    RenderTask(HdRenderPassSharedPtr pass, HdRenderPassStateSharedPtr state)
        : HdTask(SdfPath("/renderTask")), _pass(std::move(pass)), _state(std::move(state)), _synced(CheckTags(false)),
          _executed(CheckTags(true)) {}
    void Sync(HdSceneDelegate*, HdTaskContext*, HdDirtyBits* dirtyBits) override {
        _pass->Sync();
        *dirtyBits = HdChangeTracker::Clean;
    }
    void Prepare(HdTaskContext*, HdRenderIndex*) override {}
    void Execute(HdTaskContext*) override { _pass->Execute(_state, _executed); }
    TfTokenVector const& GetRenderTags() const override { return _synced; }

private:
    HdRenderPassSharedPtr _pass;
    HdRenderPassStateSharedPtr _state;
    TfTokenVector _synced;
    TfTokenVector _executed;
};

int Fail(const char* what) {
    std::fprintf(stderr, "check_runtime: FAILED: %s\n", what);
    return 1;
}

/// Binds a float32 RGBA buffer as the color AOV of `state`, seen through `camera`.
void Bind(HdRenderPassStateSharedPtr const& state, HdRenderBuffer* buffer, HdCamera const* camera, int w, int h) {
    buffer->Allocate(GfVec3i(w, h, 1), HdFormatFloat32Vec4, false);
    HdRenderPassAovBinding binding;
    binding.aovName = HdAovTokens->color;
    binding.renderBufferId = buffer->GetId();
    binding.renderBuffer = buffer;
    binding.clearValue = VtValue(GfVec4f(0));
    state->SetAovBindings({binding});
    state->SetCamera(camera);
    state->SetFraming(CameraUtilFraming(GfRect2i(GfVec2i(0, 0), w, h)));
}

/// Executes `tasks` until `pass` converges (false after `limit`), then resolves `buffer` and
/// returns its mapped pixels (nullptr when it has none); the caller unmaps.
const float* RenderUntilConverged(HdEngine& engine, HdRenderIndex* index, HdTaskSharedPtrVector& tasks,
                                  HdRenderPassSharedPtr const& pass, HdRenderBuffer* buffer, std::chrono::seconds limit) {
    const auto start = std::chrono::steady_clock::now();
    do {
        engine.Execute(index, &tasks);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        if (std::chrono::steady_clock::now() - start > limit) return nullptr;
    } while (!pass->IsConverged());
    buffer->Resolve();
    return static_cast<const float*>(buffer->Map());
}

#ifdef TIDE_CHECK_USD_IMAGING
/// Renders a USD stage through UsdImaging (its scene delegate, or with `sceneIndex` its scene
/// indices) at `samples` per pixel, seen from `cameraPath`, w × h, and prints the image's mean RGB
/// and the standard error of each mean (pixels as independent samples) for a comparison with
/// `tide render` of the same stage.
int RenderStage(const char* stagePath, const char* cameraPath, int w, int h, int samples, bool sceneIndex) {
    // the viewer's refinement (usdview's complexity), as UsdImagingGLEngine sets it
    const char* refineEnv = std::getenv("TIDE_CHECK_REFINE");
    const int refine = refineEnv ? std::atoi(refineEnv) : 0;
    UsdStageRefPtr stage = UsdStage::Open(stagePath);
    if (!stage) return Fail("cannot open the stage");
    HdPluginRenderDelegateUniqueHandle delegate =
        HdRendererPluginRegistry::GetInstance().CreateRenderDelegate(TfToken("HdTideRendererPlugin"));
    if (!delegate) return Fail("HdTideRendererPlugin did not load");
    delegate->SetRenderSetting(TfToken("tide:samples"), VtValue(samples));
    std::unique_ptr<HdRenderIndex> index(HdRenderIndex::New(delegate.Get(), {}));
    std::unique_ptr<UsdImagingDelegate> scene;
    UsdImagingSceneIndices sceneIndices;
    if (sceneIndex) {
        UsdImagingCreateSceneIndicesInfo info;
        info.stage = stage;
        sceneIndices = UsdImagingCreateSceneIndices(info);
        sceneIndices.stageSceneIndex->SetTime(UsdTimeCode(0.0));
        // as UsdImagingGLEngine does (usdview): scene globals naming the stage's render
        // settings prim (`renderSettingsPrimPath`) the active one, then the scene index
        // plugins loaded with Tide
        HdsiSceneGlobalsSceneIndexRefPtr globals = HdsiSceneGlobalsSceneIndex::New(sceneIndices.finalSceneIndex);
        std::string settingsPath;
        if (stage->GetMetadata(TfToken("renderSettingsPrimPath"), &settingsPath) && !settingsPath.empty())
            globals->SetActiveRenderSettingsPrimPath(SdfPath(settingsPath));
        HdsiLegacyDisplayStyleOverrideSceneIndexRefPtr style = HdsiLegacyDisplayStyleOverrideSceneIndex::New(globals);
        style->SetRefineLevel({true, refine});
        HdSceneIndexBaseRefPtr const appended =
            HdSceneIndexPluginRegistry::GetInstance().AppendSceneIndicesForRenderer("Tide", style, "");
        index->InsertSceneIndex(appended, SdfPath::AbsoluteRootPath());
    } else {
        scene = std::make_unique<UsdImagingDelegate>(index.get(), SdfPath::AbsoluteRootPath());
        scene->SetRefineLevelFallback(refine);
        scene->Populate(stage->GetPseudoRoot());
        scene->SetTime(UsdTimeCode(0.0));
        // as UsdImagingGLEngine does for the camera it views through (usdview): the scene
        // delegate then samples motion over that camera's shutter
        scene->SetCameraForSampling(SdfPath(cameraPath));
    }
    const SdfPath bufferPath("/__check/color");
    HdRenderBuffer* buffer = static_cast<HdRenderBuffer*>(delegate->CreateBprim(HdPrimTypeTokens->renderBuffer, bufferPath));
    HdRprimCollection collection(HdTokens->geometry, HdReprSelector(HdReprTokens->smoothHull));
    HdRenderPassSharedPtr pass = delegate->CreateRenderPass(index.get(), collection);
    HdRenderPassStateSharedPtr state = delegate->CreateRenderPassState();
    HdEngine engine;
    HdTaskSharedPtrVector tasks = {std::make_shared<RenderTask>(pass, state)};
    engine.Execute(index.get(), &tasks);
    auto const* camera = static_cast<const HdCamera*>(index->GetSprim(HdPrimTypeTokens->camera, SdfPath(cameraPath)));
    if (!camera) return Fail("the stage's camera did not reach the render index");
    Bind(state, buffer, camera, w, h);
    const float* px = RenderUntilConverged(engine, index.get(), tasks, pass, buffer, std::chrono::seconds(300));
    if (!px) return Fail("no convergence in 300 s, or no pixels");
    // a live edit through usd-core's stage, as an application makes it, then the image after it
    // (TIDE_CHECK_ADD_TARGET="REL_PATH TARGET": the target added to that relationship;
    // TIDE_CHECK_SET_TOKEN="ATTR_PATH VALUE": a token attribute set, such as a purpose)
    auto edited = [&](const char* var, auto&& edit) -> bool {
        const char* value = std::getenv(var);
        if (!value) return true;
        const std::string spec(value);
        const size_t space = spec.find(' ');
        if (space == std::string::npos || !edit(SdfPath(spec.substr(0, space)), spec.substr(space + 1))) {
            std::fprintf(stderr, "%s: no such property, or a bad value\n", var);
            return false;
        }
        buffer->Unmap();
        if (sceneIndex) {
            sceneIndices.stageSceneIndex->ApplyPendingUpdates();
        } else {
            scene->ApplyPendingUpdates();
        }
        px = RenderUntilConverged(engine, index.get(), tasks, pass, buffer, std::chrono::seconds(300));
        return px != nullptr;
    };
    if (!edited("TIDE_CHECK_ADD_TARGET", [&](SdfPath const& path, std::string const& target) {
            UsdRelationship rel = stage->GetRelationshipAtPath(path);
            return rel && rel.AddTarget(SdfPath(target));
        }))
        return Fail("the live edit failed, or no convergence after it in 300 s");
    if (!edited("TIDE_CHECK_SET_TOKEN", [&](SdfPath const& path, std::string const& token) {
            UsdAttribute attr = stage->GetAttributeAtPath(path);
            return attr && attr.Set(TfToken(token));
        }))
        return Fail("the live edit failed, or no convergence after it in 300 s");
    const int ch = HdGetComponentCount(buffer->GetFormat());
    std::printf("hydra");
    for (int c = 0; c < 3; ++c) {
        double s = 0, s2 = 0;
        for (int i = 0; i < w * h; ++i) {
            s += px[i * ch + c];
            s2 += double(px[i * ch + c]) * px[i * ch + c];
        }
        const double m = s / (w * h);
        std::printf(" %.6f %.6f", m, std::sqrt(std::max(0.0, s2 / (w * h) - m * m) / (w * h)));
    }
    // the pixel noise of red: the RMS difference of horizontal neighbours over √2 (noise
    // where the image is smooth)
    double d2 = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x + 1 < w; ++x) {
            const double d = double(px[(y * w + x + 1) * ch]) - px[(y * w + x) * ch];
            d2 += d * d;
        }
    std::printf(" %.6f\n", std::sqrt(d2 / (2.0 * h * (w - 1))));
    buffer->Unmap();
    delegate->DestroyBprim(buffer);
    return 0;
}
#endif

/// The outputs HdxTaskController binds beside the colour for a renderer other than Storm
/// (usdview, usdrecord): depth, primId, elementId and instanceId, each allocated in the format
/// the delegate's default descriptor gives (all valid). The pass must render with them; then, with the sphere moved up into the top half of the frame and the pass
/// framed as a viewer cropping a camera's view does (the camera's window mapped to a display
/// window half as large again as the buffer, about its centre: the buffer holds the middle
/// two thirds), each pixel is picked as hdx's HdxPickResult does it: rows from the bottom, the int32 primId looked up in the
/// render index, the [0, 1] depth unprojected through the pass's own view and projection
/// matrices. Pixels whose centre ray passes well inside the sphere must pick it at a point on
/// its surface, on the face elementId names (or, where the pixel's first sample may have
/// fallen on a neighbour, one next to it); those that pass well outside, nothing at depth 1.
int CheckPickingOutputs(HdRenderDelegate& delegate, HdRenderIndex* index, HdEngine& engine, HdTaskSharedPtrVector& tasks,
                        HdRenderPassSharedPtr const& pass, HdRenderPassStateSharedPtr const& state, Scene& scene) {
    const TfToken outputs[] = {HdAovTokens->color, HdAovTokens->depth, HdAovTokens->primId, HdAovTokens->elementId, HdAovTokens->instanceId};
    std::map<TfToken, HdRenderBuffer*> buffers;
    HdRenderPassAovBindingVector bindings;
    for (TfToken const& name : outputs) {
        const HdAovDescriptor desc = delegate.GetDefaultAovDescriptor(name);
        if (desc.format == HdFormatInvalid) continue;
        auto* b = static_cast<HdRenderBuffer*>(delegate.CreateBprim(HdPrimTypeTokens->renderBuffer, SdfPath("/__check/aov_" + name.GetString())));
        if (!b || !b->Allocate(GfVec3i(kSize, kSize, 1), desc.format, false)) return Fail("a task controller's render buffer could not be allocated");
        buffers[name] = b;
        HdRenderPassAovBinding binding;
        binding.aovName = name;
        binding.renderBufferId = b->GetId();
        binding.renderBuffer = b;
        binding.clearValue = desc.clearValue;
        bindings.push_back(binding);
    }
    for (TfToken const& name : outputs)
        if (!buffers.count(name)) return Fail("an output a task controller binds has no valid descriptor");
    state->SetAovBindings(bindings);
    state->SetFraming(CameraUtilFraming(GfRange2f(GfVec2f(-kSize / 4.0f), GfVec2f(kSize * 5 / 4.0f)), GfRect2i(GfVec2i(0, 0), kSize, kSize)));
    const GfVec3d centre(0, 0.8, 0);
    scene.sphereAt = centre;
    index->GetChangeTracker().MarkRprimDirty(kSphere, HdChangeTracker::DirtyTransform);
    HdRenderBuffer* color = buffers[HdAovTokens->color];
    const float* px = RenderUntilConverged(engine, index, tasks, pass, color, std::chrono::seconds(120));
    if (!px) return Fail("with a task controller's outputs bound the pass did not converge");
    color->Unmap();
    HdRenderBuffer* depthBuf = buffers[HdAovTokens->depth];
    HdRenderBuffer* primBuf = buffers[HdAovTokens->primId];
    HdRenderBuffer* instBuf = buffers[HdAovTokens->instanceId];
    HdRenderBuffer* elemBuf = buffers[HdAovTokens->elementId];
    for (HdRenderBuffer* b : {depthBuf, primBuf, instBuf, elemBuf}) b->Resolve();
    if (depthBuf->GetFormat() != HdFormatFloat32 || primBuf->GetFormat() != HdFormatInt32 || instBuf->GetFormat() != HdFormatInt32 ||
        elemBuf->GetFormat() != HdFormatInt32)
        return Fail("depth is not float32, or primId / instanceId / elementId not int32");
    const float* depth = static_cast<const float*>(depthBuf->Map());
    const int32_t* prim = static_cast<const int32_t*>(primBuf->Map());
    const int32_t* inst = static_cast<const int32_t*>(instBuf->Map());
    const int32_t* elem = static_cast<const int32_t*>(elemBuf->Map());
    const GfMatrix4d ndcToWorld = (state->GetWorldToViewMatrix() * state->GetProjectionMatrix()).GetInverse();
    const GfVec3d eye(0, 0, 4);
    int inside = 0, outside = 0, top = 0, faced = 0, onFace = 0;
    const char* failure = nullptr;
    for (int y = 0; y < kSize && !failure; ++y)
        for (int x = 0; x < kSize && !failure; ++x) {
            const int i = y * kSize + x;
            // the pixel centre's ray, from the eye through the near plane, rows from the bottom
            const GfVec3d near = ndcToWorld.Transform(GfVec3d((x + 0.5) / kSize * 2 - 1, (y + 0.5) / kSize * 2 - 1, -1));
            const GfVec3d dir = (near - eye).GetNormalized();
            const GfVec3d toCentre = centre - eye;
            const double miss = (toCentre - dir * GfDot(toCentre, dir)).GetLength();
            if (miss < 0.9) {
                ++inside;
                top += y >= kSize / 2;
                if (index->GetRprimPathFromPrimId(prim[i]) != kSphere) failure = "a pixel on the sphere does not pick it";
                else if (inst[i] != -1) failure = "a pixel on the sphere (not instanced) has an instanceId";
                else {
                    // unprojected as HdxPickResult does (there from the pixel's corner, here its
                    // centre), the depth mapped from [0, 1] to [-1, 1]
                    const GfVec3d ndc((x + 0.5) / kSize * 2 - 1, (y + 0.5) / kSize * 2 - 1, depth[i] * 2 - 1);
                    const double r = (ndcToWorld.Transform(ndc) - centre).GetLength();
                    // the depth is the pixel's first sample's, up to half a pixel (0.045 at the
                    // sphere) from the centre; the facets lie up to 1 - cos(pi / 24) inside it
                    if (r < 0.94 || r > 1.05) failure = "a pick's depth unprojects off the sphere";
                    // the face the centre ray meets on the round sphere (the facets lie within
                    // 0.009 of it): face i * 2n + j spans theta in [i, i + 1] * pi / n and phi in
                    // [j, j + 1] * pi / n (Scene's UV sphere, n = 24). Where the surface faces
                    // the camera (a pixel's footprint there, 0.06, under half a band of 0.13),
                    // the first sample's face is this one or, near a band's edge, a neighbour.
                    const double t = GfDot(toCentre, dir) - std::sqrt(std::max(0.0, 1.0 - miss * miss));
                    const GfVec3d q = eye + dir * t - centre;
                    const double theta = std::acos(std::clamp(q[1], -1.0, 1.0)), sinTheta = std::sin(theta);
                    const double phi = std::fmod(std::atan2(q[2], q[0]) + 2 * M_PI, 2 * M_PI);
                    const double facing = -GfDot(q, dir);
                    if (!failure && facing > 0.5 && sinTheta > 0.5) {
                        ++faced;
                        const int n = 24, bi = int(theta * n / M_PI), bj = int(phi * n / M_PI);
                        const int ei = elem[i] / (2 * n), ej = elem[i] % (2 * n);
                        const int dj = std::min((ej - bj + 2 * n) % (2 * n), (bj - ej + 2 * n) % (2 * n));
                        if (elem[i] < 0 || elem[i] >= 2 * n * n || std::abs(ei - bi) > 1 || dj > 1)
                            failure = "a pixel on the sphere names a face that is not where it sees the sphere";
                        onFace += ei == bi && ej == bj;
                    }
                }
            } else if (miss > 1.1) {
                ++outside;
                if (prim[i] != -1 || inst[i] != -1 || elem[i] != -1 || depth[i] != 1.0f)
                    failure = "a pixel beside the sphere picks something, or its depth is not 1";
            }
        }
    for (HdRenderBuffer* b : {depthBuf, primBuf, instBuf, elemBuf}) b->Unmap();
    if (failure) return Fail(failure);
    std::printf("picking outputs: %d pixels pick the sphere (%d in the top half), %d nothing; %d facing pixels name their face's"
                " neighbourhood, %d the face itself\n",
                inside, top, outside, faced, onFace);
    if (faced < 100 || onFace * 2 < faced) return Fail("too few pixels name the face they see");
    // magnified 1.5 times by the framing, the sphere covers more than the 220 pixels it does
    // unframed (2.25 times as many, less what leaves the top of the frame)
    if (inside < 280 || outside < 40 || top * 4 < inside * 3)
        return Fail("the sphere is not where it was moved, or not framed as the pass says (the rows' order?)");
    for (auto& [name, b] : buffers) delegate.DestroyBprim(b);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 7) {
#ifdef TIDE_CHECK_USD_IMAGING
        const std::string mode = argv[6];
        if (mode != "delegate" && mode != "sceneIndex") return Fail("MODE must be delegate or sceneIndex");
        return RenderStage(argv[1], argv[2], std::atoi(argv[3]), std::atoi(argv[4]), std::atoi(argv[5]), mode == "sceneIndex");
#else
        return Fail("built without UsdImaging (TIDE_CHECK_USD_IMAGING)");
#endif
    }
    HdPluginRenderDelegateUniqueHandle delegate =
        HdRendererPluginRegistry::GetInstance().CreateRenderDelegate(TfToken("HdTideRendererPlugin"));
    if (!delegate) return Fail("HdTideRendererPlugin did not load (is its plugInfo.json on PXR_PLUGINPATH_NAME?)");
    std::printf("loaded %s\n", delegate.GetPluginId().GetText());

    std::unique_ptr<HdRenderIndex> index(HdRenderIndex::New(delegate.Get(), {}));
    if (!index) return Fail("no render index");
    Scene scene(index.get());
    index->InsertRprim(HdPrimTypeTokens->mesh, &scene, kSphere);
    index->InsertSprim(HdPrimTypeTokens->camera, &scene, kCamera);
    index->InsertSprim(HdPrimTypeTokens->domeLight, &scene, kDome);
    index->InsertBprim(HdPrimTypeTokens->renderBuffer, &scene, kBuffer);

    HdRprimCollection collection(HdTokens->geometry, HdReprSelector(HdReprTokens->smoothHull));
    HdRenderPassSharedPtr pass = delegate->CreateRenderPass(index.get(), collection);
    HdRenderPassStateSharedPtr state = delegate->CreateRenderPassState();

    HdEngine engine;
    HdTaskSharedPtrVector tasks = {std::make_shared<RenderTask>(pass, state)};
    auto* buffer = static_cast<HdRenderBuffer*>(index->GetBprim(HdPrimTypeTokens->renderBuffer, kBuffer));
    if (!buffer) return Fail("the render buffer bprim was not created");
    // the first Execute syncs the prims (and the buffer's descriptor); then bind and render
    engine.Execute(index.get(), &tasks);
    Bind(state, buffer, static_cast<const HdCamera*>(index->GetSprim(HdPrimTypeTokens->camera, kCamera)), kSize, kSize);

    // renders until the pass converges; returns (centre, corners) means, or (-1, -1)
    auto render = [&]() -> std::pair<double, double> {
        const float* px = RenderUntilConverged(engine, index.get(), tasks, pass, buffer, std::chrono::seconds(120));
        if (!px || buffer->GetWidth() != kSize || buffer->GetHeight() != kSize) return {-1.0, -1.0};
        const int ch = HdGetComponentCount(buffer->GetFormat());
        auto mean = [&](int x0, int x1, int y0, int y1) {
            double s = 0;
            int n = 0;
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x, ++n) s += (px[(y * kSize + x) * ch] + px[(y * kSize + x) * ch + 1] + px[(y * kSize + x) * ch + 2]) / 3.0;
            return s / n;
        };
        // the sphere subtends 2·atan(1/√15) ≈ 29.9° of the 48.5° field: its middle 8 × 8
        // pixels and the frame's 4 × 4 corners are well inside and outside it
        const double centre = mean(12, 20, 12, 20);
        const double corner = (mean(0, 4, 0, 4) + mean(28, 32, 0, 4) + mean(0, 4, 28, 32) + mean(28, 32, 28, 32)) / 4.0;
        buffer->Unmap();
        return {centre, corner};
    };
    auto [centre, corner] = render();
    if (centre < 0) return Fail("the render did not converge in 120 s, or gave no pixels of the expected size");
    std::printf("centre (sphere) %.4f, corners (dome) %.4f\n", centre, corner);
    // the dome seen directly is exact; the sphere is a furnace of albedo 0.18 (the pass's
    // samples' noise and the white illuminant's uplift: 5%)
    if (std::fabs(corner - 1.0) > 0.02) return Fail("the dome does not read 1");
    if (std::fabs(centre - 0.18) > 0.18 * 0.05) return Fail("the sphere does not read 0.18");

    // an edit as Hydra reports it: the sphere moves out of view, its transform is marked dirty,
    // the pass restarts and the centre now sees the dome
    scene.sphereAt = GfVec3d(10, 0, 0);
    index->GetChangeTracker().MarkRprimDirty(kSphere, HdChangeTracker::DirtyTransform);
    std::tie(centre, corner) = render();
    if (centre < 0) return Fail("the render after the edit did not converge");
    std::printf("after moving the sphere away: centre %.4f, corners %.4f\n", centre, corner);
    if (std::fabs(centre - 1.0) > 0.02 || std::fabs(corner - 1.0) > 0.02) return Fail("the edit did not reach the render");

    // a viewer's pause and stop (usdview's Pause / Stop Render): paused, an edit's render is
    // prepared but waits; resumed, it renders; stopped, the pass says it is done; restarted,
    // it renders again
    HdRenderDelegate* hd = delegate.Get();
    if (!hd->IsPauseSupported() || !hd->IsStopSupported()) return Fail("pause or stop is not supported");
    if (!hd->Pause() || !hd->IsPaused()) return Fail("the delegate did not pause");
    scene.sphereAt = GfVec3d(0, 0, 0);
    index->GetChangeTracker().MarkRprimDirty(kSphere, HdChangeTracker::DirtyTransform);
    for (int i = 0; i < 10; ++i) {
        engine.Execute(index.get(), &tasks);
        std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
    if (pass->IsConverged()) return Fail("a paused render converged");
    if (!hd->Resume() || hd->IsPaused()) return Fail("the delegate did not resume");
    std::tie(centre, corner) = render();
    std::printf("paused, the sphere moved back, resumed: centre %.4f\n", centre);
    if (std::fabs(centre - 0.18) > 0.18 * 0.05) return Fail("the render after resuming does not show the sphere");
    if (!hd->Stop() || !hd->IsStopped() || !pass->IsConverged()) return Fail("a stopped render does not say it is done");
    if (!hd->Restart() || hd->IsStopped()) return Fail("the delegate did not restart");

    if (int failed = CheckPickingOutputs(*delegate, index.get(), engine, tasks, pass, state, scene)) return failed;
    std::printf("check_runtime: ok\n");
    return 0;
}
