//! Statistical test helpers used by the core's own tests and by downstream crates:
//! χ² goodness-of-fit of direction samplers against their pdfs, and simple moments.

pub mod chi2;
