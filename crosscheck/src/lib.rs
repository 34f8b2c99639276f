//! Cross-checks of the awfqi core: see the tests, examples and benchmarks of this crate.
