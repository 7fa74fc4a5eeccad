//! Stage 4, `visibility`: one shadow ray between every row end point (shading-point cluster
//! representatives, or shading points themselves when they are not clustered) and every column
//! end point (VPL cluster representatives, or VPLs), stored as a bit-packed matrix.
//!
//! A pair whose surfaces face away from each other gets bit 0 without a ray: light cannot pass
//! between them (a ray would be blocked by one of the two surfaces), so the ray is saved.

use crate::CpuScene;
use glam::Vec3;
use rayon::prelude::*;
use vplgi_frame::Progress;
use vplgi_types::params::FACING_COS;

pub use vplgi_types::Endpoint;
use std::ops::Range;
use vplgi_frame::FrameError;

/// A rows x cols matrix of bits, each row padded to whole 64-bit words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BitMatrix {
    pub rows: usize,
    pub cols: usize,
    words_per_row: usize,
    bits: Vec<u64>,
}

impl BitMatrix {
    pub fn new(rows: usize, cols: usize) -> BitMatrix {
        let words_per_row = cols.div_ceil(64);
        BitMatrix { rows, cols, words_per_row, bits: vec![0; rows * words_per_row] }
    }

    #[inline]
    pub fn get(&self, r: usize, c: usize) -> bool {
        (self.bits[r * self.words_per_row + c / 64] >> (c % 64)) & 1 == 1
    }

    /// Sets bit (`r`, `c`): the pair sees itself. (The stage writes whole words; tests set
    /// single pairs.)
    pub fn set(&mut self, r: usize, c: usize) {
        self.bits[r * self.words_per_row + c / 64] |= 1u64 << (c % 64);
    }

    /// The words of row `r`.
    #[inline]
    pub fn row(&self, r: usize) -> &[u64] {
        &self.bits[r * self.words_per_row..(r + 1) * self.words_per_row]
    }

    pub fn count_ones(&self) -> u64 {
        self.bits.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// The 64-bit words, row after row (`cols.div_ceil(64)` per row).
    pub fn words(&self) -> &[u64] {
        &self.bits
    }
}

/// Whether the two surfaces can see each other at all, ignoring blockers.
#[inline]
pub fn facing(a: &Endpoint, b: &Endpoint) -> bool {
    let d = b.p() - a.p();
    let bound = FACING_COS * d.length();
    a.n().dot(d) > bound && b.n().dot(d) < -bound
}

/// Shadow segments per Embree packet query: `rtcOccluded8`, the width `make perf-report`
/// measures fastest on these rays (of 4, 8 and 16; AVX-512 machines included).
pub const PACKET: usize = 8;

// A facing pair's ends lie on the positive side of each other's surface (the bound is not
// negative), so `CpuScene::offset_toward` pushes each along its own normal: the segment starts
// at the row's pushed-off end and stops at the column's, both computable once.
const _: () = assert!(FACING_COS >= 0.0);

/// 8 columns in structure-of-arrays form, for the facing test of a row against all 8 at once:
/// positions, normals, and each end pushed off its surface along its normal. Slots past the
/// last column have NaN positions, which face nothing.
#[derive(Clone, Copy)]
struct ColumnBlock {
    p: [[f32; 8]; 3],
    n: [[f32; 8]; 3],
    end: [[f32; 8]; 3],
}

impl ColumnBlock {
    fn of(cols: &[Endpoint], eps: f32) -> Vec<ColumnBlock> {
        cols.chunks(8)
            .map(|c| {
                let mut b = ColumnBlock { p: [[f32::NAN; 8]; 3], n: [[0.0; 8]; 3], end: [[0.0; 8]; 3] };
                for (k, e) in c.iter().enumerate() {
                    let end = e.p() + e.n() * eps;
                    for axis in 0..3 {
                        (b.p[axis][k], b.n[axis][k], b.end[axis][k]) = (e.position[axis], e.normal[axis], end[axis]);
                    }
                }
                b
            })
            .collect()
    }

    /// Bit k set when row end `a` and column k face each other ([`facing`]: the same floats in
    /// the same order), and the 8 segments' directions from `origin` to the columns' ends, in
    /// lane-wise loops without branches that the compiler vectorises.
    #[inline]
    fn facing(&self, a: &Endpoint, origin: Vec3) -> (u8, [[f32; 8]; 3]) {
        let (p, n) = (a.position, a.normal);
        let (mut from_a, mut from_b, mut bound) = ([0f32; 8], [0f32; 8], [0f32; 8]);
        let mut dirs = [[0f32; 8]; 3];
        for k in 0..8 {
            let d = [self.p[0][k] - p[0], self.p[1][k] - p[1], self.p[2][k] - p[2]];
            bound[k] = FACING_COS * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            from_a[k] = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            from_b[k] = self.n[0][k] * d[0] + self.n[1][k] * d[1] + self.n[2][k] * d[2];
            for (axis, o) in origin.to_array().into_iter().enumerate() {
                dirs[axis][k] = self.end[axis][k] - o;
            }
        }
        let mut mask = 0u8;
        for k in 0..8 {
            mask |= (((from_a[k] > bound[k]) & (from_b[k] < -bound[k])) as u8) << k;
        }
        (mask, dirs)
    }
}

/// The shadow segments of one row waiting to be traced, all from the row's pushed-off end: up to
/// 7 left over, plus the 8 lanes of one column block appended without branches (twice the packet
/// width of room). Directions are kept as [x, y, z] arrays, the layout of Embree's packet.
#[derive(Default)]
struct Packet {
    columns: [usize; 2 * PACKET],
    dirs: [[f32; 2 * PACKET]; 3],
    len: usize,
}

impl Packet {
    /// Appends the lanes of `mask` (columns `first` + k, directions `dirs[..][k]`): every lane is
    /// written, the length moves past the facing ones only.
    #[inline]
    fn append(&mut self, first: usize, mask: u8, dirs: &[[f32; 8]; 3]) {
        for k in 0..8 {
            let i = self.len;
            self.columns[i] = first + k;
            for (own, lanes) in self.dirs.iter_mut().zip(dirs) {
                own[i] = lanes[k];
            }
            self.len += (mask >> k & 1) as usize;
        }
    }

    /// Traces the first `count` (at most [`PACKET`]) waiting segments from `origin`, sets the bits
    /// of the visible ones in `words` and moves the rest to the front.
    fn trace(&mut self, cs: &CpuScene, origin: Vec3, count: usize, words: &mut [u64]) {
        if count == 0 {
            return;
        }
        let dirs: [[f32; PACKET]; 3] = std::array::from_fn(|axis| std::array::from_fn(|k| self.dirs[axis][k]));
        let blocked = cs.rt.occluded8_from(origin, &dirs, count, crate::SEGMENT_TNEAR, crate::SEGMENT_TFAR);
        for (k, &c) in self.columns[..count].iter().enumerate() {
            if blocked >> k & 1 == 0 {
                words[c / 64] |= 1u64 << (c % 64);
            }
        }
        self.columns.copy_within(count..self.len, 0);
        for axis in 0..3 {
            self.dirs[axis].copy_within(count..self.len, 0);
        }
        self.len -= count;
    }
}

/// Fills the visibility matrix; returns it with the number of shadow rays traced.
pub fn visibility(cs: &CpuScene, rows: &[Endpoint], cols: &[Endpoint], progress: &dyn Progress) -> (BitMatrix, u64) {
    let mut m = BitMatrix::new(rows.len(), cols.len());
    if m.words_per_row == 0 {
        return (m, 0);
    }
    progress.start("visibility", rows.len() as u64);
    let blocks = ColumnBlock::of(cols, cs.eps);
    let rays: u64 = m
        .bits
        .par_chunks_mut(m.words_per_row)
        .zip(rows)
        .map(|(words, a)| {
            // A row's facing pairs go to Embree 8 at a time (rtcOccluded8): rays from one shading
            // point are coherent. Each segment is `CpuScene::shadow_segment` (the same floats):
            // from the row's end pushed off along its normal to the column's.
            let origin = a.p() + a.n() * cs.eps;
            let mut packet = Packet::default();
            let mut rays = 0u64;
            for (i, block) in blocks.iter().enumerate() {
                let (mask, dirs) = block.facing(a, origin);
                rays += mask.count_ones() as u64;
                packet.append(8 * i, mask, &dirs);
                if packet.len >= PACKET {
                    packet.trace(cs, origin, PACKET, words);
                }
            }
            packet.trace(cs, origin, packet.len, words);
            progress.inc(1);
            rays
        })
        .sum();
    progress.finish();
    (m, rays)
}

impl vplgi_frame::stages::Visibility for CpuScene<'_> {
    fn visibility(&self, row_points: &Vec<Endpoint>, rows: Range<u32>, cols: &Vec<Endpoint>, progress: &dyn Progress) -> Result<(BitMatrix, Option<u64>), FrameError> {
        let (m, rays) = visibility(self, &row_points[rows.start as usize..rows.end as usize], cols, progress);
        Ok((m, Some(rays)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use vplgi_types::{Rng, Stream};

    /// The stage traces a row's facing pairs in packets of 8 and writes whole words; the matrix
    /// must be what the pair-by-pair definition gives: `facing` and a shadow ray over
    /// `CpuScene::shadow_segment`. Ends in the Cornell box at random, some with normals
    /// nearly in the plane of the pair (grazing) and some pairs on one wall (coplanar), and a
    /// column count that is not a multiple of 64.
    /// Bits are row-major with each row padded to whole words: a 3 x 130 matrix has 3 words per
    /// row, and a bit lands in its own row's word and nowhere else.
    #[test]
    fn bits_land_in_their_row_and_word() {
        let mut m = BitMatrix::new(3, 130);
        assert_eq!(m.words().len(), 9);
        let set = [(0, 0), (1, 64), (2, 129), (2, 63)];
        for (r, c) in set {
            m.set(r, c);
        }
        for r in 0..3 {
            for c in 0..130 {
                assert_eq!(m.get(r, c), set.contains(&(r, c)), "bit ({r}, {c})");
            }
        }
        assert_eq!(m.words(), &[1, 0, 0, 0, 1, 0, 1 << 63, 0, 2]);
        assert_eq!(m.row(2), &[1 << 63, 0, 2]);
        assert_eq!(m.count_ones(), 4);
    }

    /// The facing bound is on the cosine, FACING_COS, at every distance: a normal tilted toward
    /// the other end by half of it does not face, by twice it does, whether the ends are 0.01 or
    /// 100 apart.
    #[test]
    fn the_facing_bound_is_on_the_cosine_at_any_distance() {
        for distance in [0.01f32, 1.0, 100.0] {
            let b = Endpoint::new(Vec3::new(0.0, distance, 0.0), -Vec3::Y);
            for (scale, faces) in [(0.5, false), (2.0, true)] {
                let c = scale * FACING_COS;
                let a = Endpoint::new(Vec3::ZERO, Vec3::new((1.0 - c * c).sqrt(), c, 0.0));
                assert_eq!(facing(&a, &b), faces, "cosine {c} at distance {distance}");
                assert_eq!(facing(&b, &a), faces, "cosine {c} at distance {distance}, ends swapped");
            }
        }
    }

    #[test]
    fn the_matrix_is_facing_and_the_shadow_segment_pair_by_pair() {
        let scene = vplgi_scene::cornell::cornell_box();
        let device = vplgi_embree::Device::new(None).expect("embree");
        let cs = CpuScene::new(&scene, &device).expect("scene");
        let mut rng = Rng::new(3, Stream::Oracle, 6);
        let end = |rng: &mut Rng| {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.6 + Vec3::splat(0.2);
            let n = vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
            Endpoint::new(p, n)
        };
        let mut rows: Vec<Endpoint> = (0..40).map(|_| end(&mut rng)).collect();
        let mut cols: Vec<Endpoint> = (0..150).map(|_| end(&mut rng)).collect();
        // Coplanar ends on the floor facing up.
        rows.extend((0..5).map(|i| Endpoint::new(Vec3::new(0.3 + 0.2 * i as f32, 0.0, 0.5), Vec3::Y)));
        cols.extend((0..5).map(|i| Endpoint::new(Vec3::new(0.4 + 0.2 * i as f32, 0.0, 1.5), Vec3::Y)));
        // One row sees two columns 1 above it whose normals are at right angles to the segment
        // or tilt toward it by half the facing bound (FACING_COS): neither faces the row.
        rows.push(Endpoint::new(Vec3::new(1.0, 0.5, 1.0), Vec3::Y));
        cols.push(Endpoint::new(Vec3::new(1.0, 1.5, 1.0), Vec3::X));
        cols.push(Endpoint::new(Vec3::new(1.0, 1.5, 1.0), Vec3::new(1.0, -0.5 * FACING_COS, 0.0).normalize()));
        // Pairs at the facing bound, from 0.05 to 20 apart in several directions: a row facing up
        // from (1, 0.5, 1) and columns whose direction from it makes a cosine of half or twice
        // FACING_COS with the row's normal (the columns face the row squarely), then the same
        // with the roles swapped. Only the bound decides these pairs, at every distance.
        let at = Vec3::new(1.0, 0.5, 1.0);
        rows.push(Endpoint::new(at, Vec3::Y));
        for (i, distance) in [0.05f32, 0.3, 1.0, 3.0, 20.0].into_iter().enumerate() {
            for scale in [0.5, 2.0] {
                let (c, phi) = (scale * FACING_COS, 1.3 * i as f32 + scale);
                let dir = Vec3::new(phi.cos() * (1.0 - c * c).sqrt(), c, phi.sin() * (1.0 - c * c).sqrt());
                cols.push(Endpoint::new(at + dir * distance, -dir));
                // Swapped: a row `distance` below `at` along -dir faces it squarely, and a column
                // at `at` has a normal whose cosine with the direction back to the row is c
                // (tilted about an axis at right angles to dir).
                let tilt = Vec3::new(-phi.sin(), 0.0, phi.cos());
                rows.push(Endpoint::new(at - dir * distance, dir));
                cols.push(Endpoint::new(at, (-dir * c + tilt * (1.0 - c * c).sqrt()).normalize()));
            }
        }
        let (m, rays) = visibility(&cs, &rows, &cols, &crate::NoProgress);
        let mut facing_pairs = 0;
        for (r, a) in rows.iter().enumerate() {
            for (c, b) in cols.iter().enumerate() {
                let f = facing(a, b);
                facing_pairs += f as u64;
                let want = f && cs.visible(a.p(), a.n(), b.p(), b.n());
                assert_eq!(m.get(r, c), want, "row {r} {a:?}, column {c} {b:?}");
            }
        }
        assert_eq!(rays, facing_pairs);
        assert!(m.count_ones() > 100 && facing_pairs > m.count_ones(), "visible {} of {facing_pairs} facing pairs", m.count_ones());
    }
}
