//! tide::SceneSource: where prims pull their values from during Sync (the stand-in for
//! HdSceneDelegate), and MemorySceneSource, a concrete one filled by the Python module.
#pragma once

#include "value.h"

#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace tide {

/// The scene data a prim reads in Sync. Paths are SdfPath strings; keys are USD attribute
/// names as in the delegate protocol.
class SceneSource {
public:
    virtual ~SceneSource() = default;
    /// The value of `key` on `path` (the first time sample if there are several), or Empty.
    virtual Value Get(const std::string& path, const std::string& key) const = 0;
    /// Every sample of `key` (one untimed sample for a plain value; none if absent).
    virtual std::vector<TimedValue> SampleValues(const std::string& path, const std::string& key) const;
    /// The attribute keys authored on `path`.
    virtual std::vector<std::string> GetKeys(const std::string& path) const = 0;
    /// The primvar names authored on `path`.
    virtual std::vector<std::string> GetPrimvarNames(const std::string& path) const;
    /// A primvar (data Empty if absent).
    virtual Primvar GetPrimvar(const std::string& path, const std::string& name) const;
};

/// A SceneSource that stores what it is given. Thread-safe.
class MemorySceneSource final : public SceneSource {
public:
    /// Stores a value: untimed replaces every sample, timed adds (or replaces) one sample.
    void Set(const std::string& path, const std::string& key, TimedValue value);
    void SetPrimvar(const std::string& path, const std::string& name, Primvar primvar);
    /// Forgets everything stored for `path`.
    void Remove(const std::string& path);

    Value Get(const std::string& path, const std::string& key) const override;
    std::vector<TimedValue> SampleValues(const std::string& path, const std::string& key) const override;
    std::vector<std::string> GetKeys(const std::string& path) const override;
    std::vector<std::string> GetPrimvarNames(const std::string& path) const override;
    Primvar GetPrimvar(const std::string& path, const std::string& name) const override;

private:
    mutable std::mutex _mutex;
    std::map<std::string, std::map<std::string, std::vector<TimedValue>>> _values;
    std::map<std::string, std::map<std::string, Primvar>> _primvars;
};

}  // namespace tide
