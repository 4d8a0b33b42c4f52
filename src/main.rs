//! The `charted` command line (filled in by issue 4).
fn main() {
    println!("charted: the renderer CLI arrives with the light-transport crate");
}
