//! What the `gltf` crate trusts once its JSON validation passed, checked first: buffer views
//! inside their buffers, accessor kinds, ranges and counts.

use gltf::accessor::{DataType, Dimensions};

/// Accessors longer than this are rejected as implausible: an accessor without a buffer view
/// (sparse only) would otherwise let a tiny file request gigabytes of zeros.
pub(super) const MAX_ACCESSOR_COUNT: usize = 1 << 28;

/// Every primitive's `POSITION` names an existing accessor. The `gltf` crate's own validation
/// indexes the accessors with it before checking it (and panics on, say, 2^31), so this runs on
/// the raw JSON before that validation.
pub(super) fn check_position_accessors(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) =
                primitive.attributes.get(&Checked::Valid(gltf::json::mesh::Semantic::Positions))
            {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "mesh {m}, primitive {p}: POSITION names accessor {} but the file has {}",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Every buffer view must lie inside its buffer: the `gltf` crate slices without checking.
pub(super) fn check_views(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Result<(), String> {
    for view in document.views() {
        let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > len) {
            return Err(format!(
                "buffer view {} (bytes {}..+{}) lies outside buffer {} of {len} bytes",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index()
            ));
        }
    }
    Ok(())
}

/// Checks that reading `accessor` as elements of the allowed kinds cannot fail or panic inside
/// the `gltf` crate: the element kind matches, the count is sane, the stride covers an element
/// and the last element ends inside the buffer view (sparse parts likewise).
pub(super) fn check_accessor(
    accessor: &gltf::Accessor,
    kinds: &[(Dimensions, DataType)],
) -> Result<(), String> {
    let what = format!("accessor {}", accessor.index());
    let (dims, ty) = (accessor.dimensions(), accessor.data_type());
    if !kinds.contains(&(dims, ty)) {
        return Err(format!(
            "{what} has an unsupported element type {dims:?} of {ty:?} for its use"
        ));
    }
    let count = accessor.count();
    if count == 0 || count > MAX_ACCESSOR_COUNT {
        return Err(format!("{what} has an invalid element count {count}"));
    }
    let size = accessor.size();
    if let Some(view) = accessor.view() {
        check_range(&what, &view, accessor.offset(), count, size)?;
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!("{what} has an invalid sparse count {n}"));
        }
        let indices = sparse.indices();
        check_range(&what, &indices.view(), indices.offset(), n, indices.index_type().size())?;
        let values = sparse.values();
        check_range(&what, &values.view(), values.offset(), n, size)?;
    }
    Ok(())
}

fn check_range(
    what: &str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{what}: byte stride {stride} is smaller than its {size}-byte elements"
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(offset));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "{what}: {count} elements run past the end of buffer view {}",
            view.index()
        ));
    }
    Ok(())
}

pub(super) const VEC3_F32: &[(Dimensions, DataType)] = &[(Dimensions::Vec3, DataType::F32)];
pub(super) const SCALAR_F32: &[(Dimensions, DataType)] = &[(Dimensions::Scalar, DataType::F32)];
/// Rotation keyframes: floats or normalised integers (glTF's animation sampler rule).
pub(super) const ROTATION_KINDS: &[(Dimensions, DataType)] = &[
    (Dimensions::Vec4, DataType::F32),
    (Dimensions::Vec4, DataType::I8),
    (Dimensions::Vec4, DataType::U8),
    (Dimensions::Vec4, DataType::I16),
    (Dimensions::Vec4, DataType::U16),
];
pub(super) const UV_KINDS: &[(Dimensions, DataType)] = &[
    (Dimensions::Vec2, DataType::F32),
    (Dimensions::Vec2, DataType::U8),
    (Dimensions::Vec2, DataType::U16),
];
pub(super) const INDEX_KINDS: &[(Dimensions, DataType)] = &[
    (Dimensions::Scalar, DataType::U8),
    (Dimensions::Scalar, DataType::U16),
    (Dimensions::Scalar, DataType::U32),
];

/// Data URIs can be megabytes long: messages show their start only.
pub(super) fn short_uri(uri: &str) -> String {
    if uri.starts_with("data:") {
        let head: String = uri.chars().take(40).collect();
        format!("{head}...")
    } else {
        uri.to_string()
    }
}

/// A relative URI must percent-decode to UTF-8: the `gltf` crate unwraps that decoding.
pub(super) fn check_uri(uri: &str) -> Result<(), String> {
    if uri.contains(':') {
        return Ok(());
    }
    let hex = |b: u8| (b as char).to_digit(16);
    let bytes = uri.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        // Like the crate's decoder: "%" with two hex digits is a byte, anything else literal.
        let escaped = match bytes.get(i..i + 3) {
            Some([b'%', h, l]) => hex(*h).zip(hex(*l)).map(|(h, l)| (h * 16 + l) as u8),
            _ => None,
        };
        match escaped {
            Some(byte) => {
                decoded.push(byte);
                i += 3;
            }
            None => {
                decoded.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8(decoded)
        .map(|_| ())
        .map_err(|_| "the URI's percent escapes do not decode to UTF-8".into())
}
