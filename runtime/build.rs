//! Link settings of the release binary that no profile key can say.
//!
//! `-z pack-relative-relocs` (DT_RELR): the position-independent binary's ~50,000 relative
//! relocations packed into a bitmap instead of 24 bytes each. The dynamic loader reads the
//! whole table at every start, so it was 1.2 MB of the stripped binary and about as much of a
//! running PLC's resident memory (numbers in the workspace's Cargo.toml). It needs GNU ld 2.38
//! and, at run time, glibc 2.36 (Debian 12, Raspberry Pi OS 12, Ubuntu 24.04), which the
//! package's dependencies say; `SOFTPLC_PACK_RELOCATIONS=0 cargo build --release` builds for
//! an older system. Debug and test builds keep the default: they run where they were built.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=SOFTPLC_PACK_RELOCATIONS");
    let var = |name: &str| std::env::var(name).unwrap_or_default();
    if var("PROFILE") == "release"
        && var("CARGO_CFG_TARGET_OS") == "linux"
        && var("CARGO_CFG_TARGET_ENV") == "gnu"
        && var("SOFTPLC_PACK_RELOCATIONS") != "0"
    {
        println!("cargo:rustc-link-arg-bin=softplc=-Wl,-z,pack-relative-relocs");
    }
}
