//! Runs the C++ layer's self checks (cpp/selfTest.cpp) through the cxx bridge.

#[test]
fn cpp_layer_self_tests_pass() {
    let dir = std::env::temp_dir().join(format!("tide-bridge-selftest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let failures = tide_bridge::ffi::RunSelfTests(dir.to_str().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "C++ self tests failed:\n{failures}");
}
