//! The C++ layer's self checks, run from `cargo test -p tide-bridge`.
#pragma once

#include "rust/cxx.h"

namespace tide {
namespace rs {
/// Runs the checks; returns the failures, one a line ("" when all passed).
rust::String RunSelfTests(rust::Str scratch_dir);
}  // namespace rs
}  // namespace tide
