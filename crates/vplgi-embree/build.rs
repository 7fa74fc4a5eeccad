//! embree4-sys only asks for `-lembree4`; tell the linker where ci/install-deps.sh put the runtime.
//! `rustc-link-search` propagates to every binary, test and bench that links this crate. At run
//! time the library is found through the ldconfig entry the install script writes.
fn main() {
    let dir = std::env::var("VPLGI_EMBREE_DIR")
        .unwrap_or_else(|_| "/usr/local/lib/vplgi-embree4".to_string());
    println!("cargo:rerun-if-env-changed=VPLGI_EMBREE_DIR");
    println!("cargo:rustc-link-search=native={dir}");
}
