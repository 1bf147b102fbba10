//! `lfdepth`: the command-line tool.

fn main() {
    println!("lfdepth {}", env!("CARGO_PKG_VERSION"));
}
