//! The C++ layer's self checks (run by `cargo test -p tide-bridge`): prim lifetimes in any
//! order, Rust errors becoming problems, render buffer allocation, an OpenImageIO-written
//! float texture read back exactly through the TextureCache into the delegate.
#include "tide/selfTest.h"
#include "tide/renderBuffer.h"
#include "tide/renderDelegate.h"
#include "tide/renderIndex.h"
#include "tide/renderParam.h"
#include "tide/texture.h"

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <sstream>
#include <string>

namespace tide {
namespace rs {

namespace {

struct Checker {
    std::ostringstream out;
    void Check(bool ok, const std::string& what) {
        if (!ok) out << what << "\n";
    }
};

bool HasProblem(const std::vector<Problem>& ps, const std::string& prim, const std::string& attr) {
    for (const auto& p : ps)
        if (p.prim == prim && p.attribute == attr) return true;
    return false;
}

void Lifetimes(Checker& c) {
    MemorySceneSource source;
    RenderDelegate delegate;
    {
        RenderIndex index(&delegate, &source);
        const char* types[] = {"mesh", "material", "renderBuffer", "sphere", "domeLight", "camera"};
        for (int round = 0; round < 3; ++round) {
            for (int i = 0; i < 6; ++i)
                c.Check(index.InsertPrim(types[i], "/P" + std::to_string(i)), std::string("insert ") + types[i]);
            // Destroy in a different order each round; re-insert over live prims.
            static const int orders[3][6] = {{0, 1, 2, 3, 4, 5}, {5, 4, 3, 2, 1, 0}, {2, 5, 0, 3, 1, 4}};
            for (int k : orders[round]) c.Check(index.RemovePrim("/P" + std::to_string(k)), "remove a live prim");
            c.Check(index.GetPrimCount() == 0, "all prims removed");
            c.Check(index.InsertPrim("mesh", "/X") && index.InsertPrim("sphere", "/X"), "replace a prim");
            index.SyncAll();
            c.Check(index.RemovePrim("/X") && !index.RemovePrim("/X"), "remove the replaced prim once");
        }
        c.Check(!index.InsertPrim("teapot", "/T"), "unknown type refused");
        index.SyncAll();
        c.Check(HasProblem(delegate.TakeProblems(), "/T", ""), "unknown type is a problem");
        // The index is destroyed with prims alive: it destroys them.
    }
}

void ErrorsBecomeProblems(Checker& c) {
    MemorySceneSource source;
    RenderDelegate delegate;
    RenderIndex index(&delegate, &source);
    index.InsertPrim("mesh", "/M");
    TimedValue bad;
    bad.value = Value::MakeFloats({1.0f, 2.0f}, 3);  // 2 values do not make tuples of 3
    source.Set("/M", "points", bad);
    index.MarkAttributeDirty("/M", "points");
    index.SyncAll();
    c.Check(HasProblem(delegate.TakeProblems(), "/M", "points"), "a Rust error on forward becomes a problem");

    index.InsertPrim("renderBuffer", "/B");
    RenderBuffer* rb = index.GetRenderBuffer("/B");
    c.Check(rb && !rb->Allocate(0, 10, 1, Format::Float32Vec4), "zero-width buffer refused");
    c.Check(rb && rb->Allocate(3, 2, 1, Format::Float32Vec3), "3x2 buffer allocated");
    if (rb) {
        c.Check(rb->GetWidth() == 3 && rb->GetHeight() == 2 && rb->GetChannels() == 3, "buffer dims");
        rb->Resolve();
        rb->Map();
        c.Check(rb->IsMapped(), "mapped");
        rb->Unmap();
        c.Check(!rb->IsMapped(), "unmapped");
    }
    std::string error;
    auto pass = delegate.CreateRenderPass();
    c.Check(!pass->Execute(RenderPassState{"/NoCamera", {}, ""}, &error) && !error.empty(),
            "execute without a camera is an error, not an abort");
}

void Textures(Checker& c, const std::string& dir) {
    const std::string path = dir + "/selftest_texture.exr";
    const float pixels[2 * 2 * 3] = {0.0f, 0.5f, 1.0f, 2.0f, 4.0f, 0.25f, 0.125f, 8.0f, 16.0f, 0.75f, 0.0625f, 3.0f};
    auto out = OIIO::ImageOutput::create(path);
    c.Check(bool(out), "EXR writer available");
    if (!out) return;
    OIIO::ImageSpec spec(2, 2, 3, OIIO::TypeDesc::FLOAT);
    c.Check(out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, pixels) && out->close(), "EXR written");

    RenderDelegate delegate;
    RenderParam& param = *delegate.GetRenderParam();
    c.Check(LoadTextureFor(param, "/Looks/M", "/Looks/M/Tex.inputs:file", path), "EXR texture loaded");
    MappedBuffer m = param.GetDelegate().texture_pixels(path);
    c.Check(m.width == 2 && m.height == 2 && m.channels == 3, "texture dims reach the delegate");
    bool same = m.pixels.size() == 12;
    for (size_t i = 0; same && i < 12; ++i) same = m.pixels[i] == pixels[i];  // float EXR: exact
    c.Check(same, "float EXR pixels reach the delegate unchanged (no sRGB decode)");

    // A file's wrap metadata (what maketx writes) comes through; a file without names none.
    TextureCache cache;
    TextureImage plain, wrapped;
    std::string error;
    c.Check(cache.Read(path, &plain, &error) && plain.wrapmodes.empty(), "a file without wrap metadata names none");
    const std::string wrappedPath = dir + "/selftest_wrapped.exr";
    auto wout = OIIO::ImageOutput::create(wrappedPath);
    spec.attribute("wrapmodes", "clamp,periodic");
    c.Check(wout && wout->open(wrappedPath, spec) && wout->write_image(OIIO::TypeDesc::FLOAT, pixels) && wout->close(),
            "EXR with wrapmodes written");
    c.Check(cache.Read(wrappedPath, &wrapped, &error) && wrapped.wrapmodes == "clamp,periodic",
            "a file's wrapmodes metadata is read (got '" + wrapped.wrapmodes + "')");

    c.Check(!LoadTextureFor(param, "/Looks/M", "/Looks/M/Other.inputs:file", dir + "/missing.png"),
            "missing texture fails");
    c.Check(HasProblem(param.TakeProblems(), "/Looks/M", "/Looks/M/Other.inputs:file"),
            "missing texture names prim and attribute");
}

// A pass marks the buffers it renders converged through the render param's registry of live
// buffers: one destroyed while the pass still holds its binding is not touched (the pass used
// to keep the pointer and write to freed memory), and one made again under the same id is the
// one marked.
void BuffersRemovedUnderAPass(Checker& c) {
    MemorySceneSource source;
    RenderDelegate delegate;
    RenderIndex index(&delegate, &source);
    RenderParam& param = *delegate.GetRenderParam();
    index.InsertPrim("renderBuffer", "/B");
    RenderBuffer* first = index.GetRenderBuffer("/B");
    param.SetBuffersConverged({"/B"}, true);
    c.Check(first && first->IsConverged(), "a live buffer is marked through the registry");
    auto pass = delegate.CreateRenderPass();
    RenderPassState state{"/NoCamera", {{"color", "/B", first, {}}}, ""};
    std::string error;
    pass->Execute(state, &error);
    c.Check(first && !first->IsConverged(), "execute clears its buffers' convergence");
    index.RemovePrim("/B");
    pass->IsConverged();
    index.InsertPrim("renderBuffer", "/B");
    RenderBuffer* second = index.GetRenderBuffer("/B");
    param.SetBuffersConverged({"/B"}, true);
    c.Check(second && second->IsConverged(), "a buffer made again under the id is the one marked");
    index.RemovePrim("/B");
    pass->IsConverged();
}

}  // namespace

rust::String RunSelfTests(rust::Str scratch_dir) {
    Checker c;
    try {
        Lifetimes(c);
        ErrorsBecomeProblems(c);
        BuffersRemovedUnderAPass(c);
        Textures(c, std::string(scratch_dir));
    } catch (const std::exception& e) {
        c.out << "exception escaped: " << e.what() << "\n";
    }
    return rust::String(c.out.str());
}

}  // namespace rs
}  // namespace tide
