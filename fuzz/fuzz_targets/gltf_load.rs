//! The glTF loader on arbitrary bytes, as a `.glb` and as a `.gltf` (JSON) file. It must return a
//! scene or an error, and the error must come from vplgi's own checks: the loader turns a panic
//! inside the `gltf` crate into "malformed glTF data", which here counts as a crash, because it
//! means a malformed input got past the checks.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // Relative URIs resolve against a directory that holds nothing.
    for name in ["/nonexistent-vplgi-fuzz/input.glb", "/nonexistent-vplgi-fuzz/input.gltf"] {
        if let Err(e) = vplgi_scene::Scene::load_slice(Path::new(name), data) {
            let message = e.to_string();
            assert!(
                !message.contains("malformed glTF data"),
                "a panic inside the gltf crate: {message}"
            );
        }
    }
});
