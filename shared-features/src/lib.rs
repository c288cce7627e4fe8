//! No code. The `acq` binary and the Python binding (`python/`) both depend
//! on this crate, so both dependency graphs ask for the same features of
//! every third-party crate they share. Cargo keys a build by its features:
//! without this, `pip install ./python` after `cargo build --release`
//! compiled the whole workspace a second time (94 s in a fresh clone, on two
//! cores), because arrow's `ffi`, bitflags' `std` and syn's `extra-traits`
//! differed between the two.
//!
//! `tests/architecture.rs` compares the two graphs' features and fails with
//! the crate and features to add to this crate's `Cargo.toml`.
