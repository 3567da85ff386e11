//! Builds the C++ layer with cxx-build and links OpenImageIO and OpenColorIO (found with
//! pkg-config) and OpenVDB (volumes' grids). With the `python` feature, also the CPython
//! module (headers from the interpreter's sysconfig, libpython not linked: the interpreter
//! provides its symbols).

use std::path::PathBuf;
use std::process::Command;

fn pkg_config(lib: &str, what: &str) -> Vec<String> {
    let out = Command::new("pkg-config").args([what, lib]).output();
    match out {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).split_whitespace().map(str::to_string).collect(),
        _ => panic!("pkg-config cannot find {lib}: run scripts/setup.sh (it installs libopenimageio-dev and libopencolorio-dev)"),
    }
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let python = std::env::var("CARGO_FEATURE_PYTHON").is_ok();

    let mut sources = vec!["cpp/value.cpp", "cpp/prims.cpp", "cpp/renderDelegate.cpp", "cpp/texture.cpp", "cpp/preview.cpp", "cpp/selfTest.cpp", "cpp/vdb.cpp"];
    if python {
        sources.push("cpp/pythonModule.cpp");
    }

    let mut build = cxx_build::bridge("src/lib.rs");
    build
        .files(&sources)
        .include(manifest.join("include"))
        .std("c++17")
        .flag_if_supported("-Wall")
        .flag_if_supported("-Wno-deprecated-declarations")
        .flag_if_supported("-Wno-missing-field-initializers")
        .define("TIDE_OCIO_DIR", format!("\"{}\"", manifest.join("ocio").display()).as_str());
    for lib in ["OpenImageIO", "OpenColorIO"] {
        for flag in pkg_config(lib, "--cflags") {
            if let Some(dir) = flag.strip_prefix("-I") {
                build.include(dir);
            } else {
                build.flag(&flag);
            }
        }
    }
    if python {
        let out = Command::new(std::env::var("PYTHON").unwrap_or_else(|_| "python3".into()))
            .args(["-c", "import sysconfig; print(sysconfig.get_paths()['include'])"])
            .output()
            .expect("python3 is needed to find Python.h");
        let include = String::from_utf8_lossy(&out.stdout).trim().to_string();
        assert!(!include.is_empty(), "python3 did not report its include dir");
        build.include(include);
    }
    build.compile("tide-bridge-cxx");

    for lib in ["OpenImageIO", "OpenColorIO"] {
        for flag in pkg_config(lib, "--libs") {
            if let Some(dir) = flag.strip_prefix("-L") {
                println!("cargo:rustc-link-search=native={dir}");
            } else if let Some(name) = flag.strip_prefix("-l") {
                println!("cargo:rustc-link-lib={name}");
            }
        }
    }
    // OpenVDB (Debian's libopenvdb-dev ships no pkg-config file; headers in the default path)
    for lib in ["openvdb", "tbb"] {
        println!("cargo:rustc-link-lib={lib}");
    }
    println!("cargo:rerun-if-changed=src/lib.rs");
    println!("cargo:rerun-if-changed=cpp");
    println!("cargo:rerun-if-changed=include");
    println!("cargo:rerun-if-env-changed=PYTHON");
}
