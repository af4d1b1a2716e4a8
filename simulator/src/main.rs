//! `simulator`: a thin command line over the simulator library.

fn main() -> anyhow::Result<()> {
    Ok(())
}
