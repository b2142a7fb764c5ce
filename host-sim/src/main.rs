//! host-sim command line (being built).
fn main() {}
