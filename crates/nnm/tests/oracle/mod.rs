//! Exact references for the integration tests, independent of the harmonic-balance solver
//! (kept apart from `tests/common`). Use from an integration test with `mod oracle;`.
#![allow(dead_code)]

pub mod impact;
