//! glTF 2.0 (`.gltf` with its buffers and images beside it, or `.glb`) to a flat world-space
//! [`Scene`].
//!
//! What is read: the default (else the first) scene's node tree with its transforms; triangle
//! list primitives; base colour factor and texture (sRGB decoded to linear); emissive factor times
//! `KHR_materials_emissive_strength`; the surface a material scatters like, from its metallic and
//! roughness factors, `KHR_materials_transmission`, `_ior` and `_volume` ([`material`]: the table
//! of `vplgi_shared::bsdf`); `KHR_lights_punctual` point and spot lights; the first perspective
//! camera. Anything else that would change the picture is skipped with a warning on stderr,
//! printed once per kind and file; so is every surface that is not diffuse, because the frame
//! shades every surface as diffuse until specular paths exist.
//!
//! A broken file must give a [`SceneError`] naming it, never a crash. The `gltf` crate trusts
//! accessor and buffer-view ranges and types once its JSON validation passed, and asserts or
//! panics on inconsistent ones, so everything it would slice or unwrap is checked here first.
//!
//! By concern: this module reads the file and its buffers; [`checks`] validates what the `gltf`
//! crate would otherwise trust; [`loader`] flattens the node tree into the scene; [`material`]
//! maps a material's factors to its surface; [`texture`] decodes images.

mod checks;
mod loader;
mod material;
#[cfg(test)]
mod tests;
mod texture;

use crate::{Scene, SceneError};
use checks::{check_position_accessors, check_uri, check_views, short_uri};
use loader::Loader;
use std::path::Path;

/// Extensions that may be listed in `extensionsRequired`. `KHR_texture_transform` is accepted
/// although its transform is ignored (with a warning): the textures still mostly look right.
const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Loads a `.gltf` or `.glb` file into a world-space triangle soup.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path)
        .map_err(|source| SceneError::Io { path: path.to_path_buf(), source })?;
    load_slice(path, &bytes)
}

/// Loads the glTF or GLB file content `bytes` as if read from `path` (which names it in errors
/// and against which relative URIs resolve): what the fuzz target feeds.
pub fn load_slice(path: &Path, bytes: &[u8]) -> Result<Scene, SceneError> {
    // The checks below cover every malformed input known to upset the `gltf` crate; this is
    // the last line of defence for what they miss, so that a bad file still cannot take the
    // whole renderer down.
    let result = quietly(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| load_bytes(path, bytes)))
    });
    let scene = match result {
        Ok(scene) => scene?,
        Err(payload) => {
            let why = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            return Err(invalid(path, format!("malformed glTF data ({why})")));
        }
    };
    scene.validate().map_err(|message| invalid(path, format!("inconsistent scene: {message}")))?;
    Ok(scene)
}

thread_local! {
    /// Whether a panic on this thread is caught and reported as an error (see [`quietly`]).
    static CAUGHT: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with the panic message of this thread silenced: `load` turns a panic inside the
/// `gltf` crate into an error naming the file, and the user must see that one line, not the
/// panic's message and backtrace too. Panics on other threads, or outside `f`, still print.
fn quietly<T>(f: impl FnOnce() -> T) -> T {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !CAUGHT.with(|c| c.get()) {
                previous(info);
            }
        }));
    });
    let before = CAUGHT.with(|c| c.replace(true));
    let out = f();
    CAUGHT.with(|c| c.set(before));
    out
}

fn invalid(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Invalid { path: path.to_path_buf(), message: message.into() }
}

fn unsupported(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Unsupported { path: path.to_path_buf(), message: message.into() }
}

fn load_bytes(path: &Path, bytes: &[u8]) -> Result<Scene, SceneError> {
    // Parse without validation first so that an unknown required extension is reported as
    // such, rather than as the crate's terse "extensionsRequired[0]: unsupported".
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| invalid(path, format!("not a readable glTF file: {e}")))?;
    let unknown: Vec<&str> = document
        .extensions_required()
        .filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e))
        .collect();
    if !unknown.is_empty() {
        return Err(unsupported(
            path,
            format!(
                "the file requires the glTF extension(s) {} (supported: {})",
                unknown.join(", "),
                SUPPORTED_REQUIRED_EXTENSIONS.join(", ")
            ),
        ));
    }
    let root = document.into_json();
    check_position_accessors(&root)
        .map_err(|m| invalid(path, format!("not a valid glTF 2.0 document: {m}")))?;
    let document = gltf::Document::from_json(root)
        .map_err(|e| invalid(path, format!("not a valid glTF 2.0 document: {e}")))?;

    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, &document, base, blob)?;
    check_views(&document, &buffers).map_err(|m| invalid(path, m))?;

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut loader = Loader::new(path, base, &document, &buffers, name);
    loader.traverse()?;
    loader.finish()
}

/// Reads every buffer, naming the failing one (a missing `.bin` beside the file is the usual
/// cause).
fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let what = match buffer.source() {
            gltf::buffer::Source::Bin => {
                format!("buffer {} (the GLB binary chunk)", buffer.index())
            }
            gltf::buffer::Source::Uri(uri) => {
                format!("buffer {} ({})", buffer.index(), short_uri(uri))
            }
        };
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            check_uri(uri).map_err(|m| invalid(path, format!("{what}: {m}")))?;
        }
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob)
            .map_err(|e| invalid(path, format!("cannot load {what}: {e}")))?;
        if data.len() < buffer.length() {
            return Err(invalid(
                path,
                format!("{what} has {} bytes but declares {}", data.len(), buffer.length()),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}
