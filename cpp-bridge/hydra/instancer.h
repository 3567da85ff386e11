//! HdTideInstancer: an HdInstancer that samples its instance primvars and transform over the
//! shutter and flattens nested instancers into the `instanceTransforms` a Tide rprim takes.
#pragma once

#include "pxr/base/gf/matrix4d.h"
#include "pxr/base/vt/types.h"
#include "pxr/imaging/hd/instancer.h"
#include "pxr/imaging/hd/timeSampleArray.h"
#include "pxr/pxr.h"
#include "tide/value.h"

#include <set>
#include <string>
#include <utility>
#include <vector>

PXR_NAMESPACE_OPEN_SCOPE

/// Per-instance world placements of one prototype: one matrix array per time (frame offsets
/// from the current frame, like Hydra's samples), every array with one matrix per instance.
struct HdTideInstanceSamples {
    std::vector<float> times;
    std::vector<VtMatrix4dArray> transforms;
};

class HdTideInstancer final : public HdInstancer {
public:
    HdTideInstancer(HdSceneDelegate* delegate, SdfPath const& id);

    /// Re-reads the instancer transform and the hydra:instance* primvars (every sample Hydra
    /// has over the shutter). Called through HdInstancer::_SyncInstancerAndParents.
    void Sync(HdSceneDelegate* sceneDelegate, HdRenderParam* renderParam, HdDirtyBits* dirtyBits) override;

    /// The placements of `prototypeId`'s instances, nested instancers flattened (each child
    /// instance repeated under each parent instance), at the union of every level's sample
    /// times; a single untimed sample (times = {0}) when nothing moves. Hydra's composition:
    /// M = instanceTransform · scale · rotate · translate · instancerTransform (row vectors),
    /// then the parent level's M after it.
    HdTideInstanceSamples SampleInstanceTransforms(SdfPath const& prototypeId);

    /// This level's per-instance primvars (instance-rate, but the placement ones) for
    /// `prototypeId`'s instances, in the order of SampleInstanceTransforms (repeated under each
    /// parent instance), then the parent levels' for the names this one lacks (each parent
    /// instance's value over the instances it places), as `instance` primvars of floats;
    /// unreadable ones are skipped.
    std::vector<std::pair<std::string, tide::Primvar>> InstancePrimvars(SdfPath const& prototypeId);

    /// The light-link categories of `prototypeId`'s instances, in the order of
    /// SampleInstanceTransforms: each instance's own (HdSceneDelegate::GetInstanceCategories)
    /// with those of the parent instances that place it.
    std::vector<std::set<TfToken>> InstanceCategories(SdfPath const& prototypeId);

private:
    /// Every sample time of this level and its parents.
    void _Times(std::vector<float>* times) const;
    /// This level's placements of `prototypeId` at `time`, flattened over the parents.
    VtMatrix4dArray _TransformsAt(SdfPath const& prototypeId, float time);

    HdTimeSampleArray<GfMatrix4d, 4> _xform;
    HdTimeSampleArray<VtValue, 4> _translations, _rotations, _scales, _matrices;
};

PXR_NAMESPACE_CLOSE_SCOPE
