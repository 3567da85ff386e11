"""Tide: a spectral path tracer for water, driven through USD.

`tide._tide` is the render delegate (C++ bridge over the Rust delegate), built by
`scripts/setup.sh` (`cargo build --release -p tide-bridge --features python`, copied here as
`_tide.so`).
"""
