//! Tide's Hydra-shaped prims: Rprim (Mesh, BasisCurves, Points, ImplicitGprim), Sprim (Material, Light,
//! Camera, RenderSettings) and Bprim bases. `Sync` pulls the dirty attributes from a
//! SceneSource and forwards them to the Rust delegate; `Finalize` lets go of Rust state.
#pragma once

#include "changeTracker.h"
#include "sceneSource.h"

#include <string>

namespace tide {

class RenderParam;

/// What every prim has: its SdfPath, its type token and the shared RenderParam.
class Prim {
public:
    Prim(const std::string& id, const std::string& typeId, RenderParam* param);
    virtual ~Prim();
    Prim(const Prim&) = delete;
    Prim& operator=(const Prim&) = delete;

    const std::string& GetId() const { return _id; }
    const std::string& GetTypeId() const { return _typeId; }
    virtual DirtyBits GetInitialDirtyBitsMask() const { return ChangeTracker::AllDirty; }

    /// Pulls what `*dirtyBits` says changed and forwards it; clears `*dirtyBits`.
    virtual void Sync(SceneSource& source, DirtyBits* dirtyBits);
    /// Called before destruction: removes the prim from the Rust delegate.
    virtual void Finalize();

protected:
    /// Forwards every sample of the keys whose bits intersect `bits`.
    void _SyncKeys(SceneSource& source, DirtyBits bits);
    /// Forwards every primvar.
    void _SyncPrimvars(SceneSource& source);

    std::string _id;
    std::string _typeId;
    RenderParam* _param;
    bool _finalized = false;
};

class Rprim : public Prim {
public:
    using Prim::Prim;
};

class Sprim : public Prim {
public:
    using Prim::Prim;
};

class Bprim : public Prim {
public:
    using Prim::Prim;
};

/// A polygon mesh (`mesh`; also `tideOcean` and `volume`, which share its data path).
class Mesh final : public Rprim {
public:
    using Rprim::Rprim;
};

/// Curves drawn as tubes, or as ribbons where they have normals (`basisCurves`).
class BasisCurves final : public Rprim {
public:
    using Rprim::Rprim;
};

/// Points drawn as spheres (`points`).
class Points final : public Rprim {
public:
    using Rprim::Rprim;
};

/// sphere, cube, cylinder, cone, capsule, plane.
class ImplicitGprim final : public Rprim {
public:
    using Rprim::Rprim;
};

/// A material network. Sync reads the textures its UsdUVTexture nodes name (OpenImageIO)
/// and hands them to Rust before the network itself.
class Material final : public Sprim {
public:
    using Sprim::Sprim;
    void Sync(SceneSource& source, DirtyBits* dirtyBits) override;
};

/// Any UsdLux light; a dome light's `inputs:texture:file` is read like a material texture.
class Light final : public Sprim {
public:
    using Sprim::Sprim;
    void Sync(SceneSource& source, DirtyBits* dirtyBits) override;
};

class Camera final : public Sprim {
public:
    using Sprim::Sprim;
};

class RenderSettings final : public Sprim {
public:
    using Sprim::Sprim;
};

/// Reads `asset` with the cache and hands it to Rust (add_texels, or
/// texture_failed), unless it was handed over unchanged on disk since. The values go as the file
/// holds them: the delegate decodes them by each user's `sourceColorSpace`. False with the
/// reason in `*error` when the file cannot be read.
bool SendTexture(RenderParam& param, const std::string& asset, std::string* error);

/// SendTexture, a failure recorded as a problem naming `prim` and `attribute`.
bool LoadTextureFor(RenderParam& param, const std::string& prim, const std::string& attribute,
                    const std::string& asset);

}  // namespace tide
