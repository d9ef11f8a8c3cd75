//! The `dbe` command.
fn main() {}
