//! The cleave server. The gRPC service is not built yet (issue 3); until it
//! is, this binary only reports its version.

fn main() {
    println!("cleave-server {} (the gRPC service is not implemented yet; use `cleave run`)", cleave::VERSION);
}
