//! tide::Value: the tagged attribute value that flows from a SceneSource into the Rust
//! delegate (the protocol's Value), plus time samples and primvars.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace tide {

enum class ValueType {
    Empty, Bool, Int, Float, Token, String, Asset, Path, Paths, Floats, Doubles, Ints, Matrix
};

/// One attribute value. Only the member matching `type` is meaningful.
struct Value {
    ValueType type = ValueType::Empty;
    bool b = false;
    int64_t i = 0;
    double f = 0.0;
    /// Token, String, Asset (resolved path) or Path text.
    std::string s;
    std::vector<std::string> paths;
    std::vector<float> floats;
    std::vector<double> doubles;
    std::vector<int32_t> ints;
    /// Components per element of `floats` / `doubles`.
    uint32_t tuple = 1;
    /// USD's row-major, row-vector matrix (translation in 12..14).
    std::array<double, 16> matrix{};

    bool IsEmpty() const { return type == ValueType::Empty; }
    /// The text of a Token / String / Asset / Path value, "" otherwise.
    const std::string& Text() const;
    static const char* TypeName(ValueType t);

    static Value MakeBool(bool v);
    static Value MakeInt(int64_t v);
    static Value MakeFloat(double v);
    static Value MakeToken(std::string v);
    static Value MakeString(std::string v);
    static Value MakeAsset(std::string v);
    static Value MakePath(std::string v);
    static Value MakePaths(std::vector<std::string> v);
    static Value MakeFloats(std::vector<float> v, uint32_t tuple);
    static Value MakeDoubles(std::vector<double> v, uint32_t tuple);
    static Value MakeInts(std::vector<int32_t> v);
    static Value MakeMatrix(const std::array<double, 16>& m);
};

/// A value at a time (offset in frames from the current frame), or the one value.
struct TimedValue {
    bool hasTime = false;
    double time = 0.0;
    Value value;
};

/// A primvar: interpolation (constant|uniform|varying|vertex|faceVarying, or instance: one element
/// per instance of instanceTransforms), data (Floats, Doubles or Ints) and optional indices.
struct Primvar {
    std::string interpolation;
    Value data;
    bool indexed = false;
    std::vector<int32_t> indices;
};

/// A problem found in the input: which prim, which attribute, what is wrong.
struct Problem {
    std::string prim;
    std::string attribute;
    std::string message;
};

}  // namespace tide
