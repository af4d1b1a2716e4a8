//! `slam-service`: a thin `main` over the service runtime.

fn main() {}
