//! `cargo xtask`: build and test orchestration.

fn main() {
    println!("usage: cargo xtask test|web|bench");
}
