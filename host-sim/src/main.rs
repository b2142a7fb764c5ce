//! host-sim: the tunnel simulator and engineer's CLI. Not built yet: see the host-sim issue.

fn main() {
    eprintln!("host-sim is not built yet; see ARCHITECTURE.md");
    std::process::exit(2);
}
