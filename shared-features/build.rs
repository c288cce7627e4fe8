//! Empty: cargo reads a package's build dependencies only when it has a build
//! script, and this package's build dependencies are the features that the
//! proc-macro crates of the binary and the binding must share.

fn main() {}
