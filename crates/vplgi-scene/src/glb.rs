//! The binary glTF container: a 12-byte header, then the JSON chunk and the BIN chunk (left out
//! when empty), each padded to 4 bytes (JSON with spaces, BIN with zeros). One builder for the
//! scene writer and the loader's tests.

/// The `.glb` bytes of a glTF JSON document and its binary buffer.
pub fn container(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let padded = |data: &[u8], fill: u8| {
        let mut v = data.to_vec();
        v.resize(v.len().next_multiple_of(4), fill);
        v
    };
    let (json, bin) = (padded(json, b' '), padded(bin, 0));
    let mut chunks = Vec::new();
    for (kind, data) in [(b"JSON", &json), (b"BIN\0", &bin)] {
        if !data.is_empty() {
            chunks.extend((data.len() as u32).to_le_bytes());
            chunks.extend_from_slice(kind);
            chunks.extend_from_slice(data);
        }
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((12 + chunks.len() as u32).to_le_bytes());
    out.extend(chunks);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_are_padded_and_an_empty_bin_is_left_out() {
        let g = container(b"{}", &[1, 2, 3, 4, 5]);
        assert_eq!(&g[..4], b"glTF");
        assert_eq!(u32::from_le_bytes(g[8..12].try_into().unwrap()) as usize, g.len());
        assert_eq!(&g[12..20], &[4, 0, 0, 0, b'J', b'S', b'O', b'N']);
        assert_eq!(&g[20..24], b"{}  ");
        assert_eq!(&g[24..32], &[8, 0, 0, 0, b'B', b'I', b'N', 0]);
        assert_eq!(&g[32..], &[1, 2, 3, 4, 5, 0, 0, 0]);
        assert_eq!(container(b"{}", &[]).len(), 12 + 8 + 4);
    }
}
