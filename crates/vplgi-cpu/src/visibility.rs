//! Stage 4, `visibility`: one shadow ray between every row end point (shading-point cluster
//! representatives, or shading points themselves when they are not clustered) and every column
//! end point (VPL cluster representatives, or VPLs), stored as a bit-packed matrix.
//!
//! A pair whose surfaces face away from each other gets bit 0 without a ray: light cannot pass
//! between them (a ray would be blocked by one of the two surfaces), so the ray is saved.

use crate::CpuScene;
use rayon::prelude::*;
use vplgi_frame::Progress;
use vplgi_types::params::FACING_COS;

pub use vplgi_types::Endpoint;

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

    pub fn set(&mut self, r: usize, c: usize, v: bool) {
        let w = &mut self.bits[r * self.words_per_row + c / 64];
        let mask = 1u64 << (c % 64);
        if v {
            *w |= mask
        } else {
            *w &= !mask
        }
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

/// Up to 8 shadow segments of one row, waiting to be traced together.
#[derive(Default)]
struct Packet {
    columns: [usize; 8],
    origins: [glam::Vec3; 8],
    dirs: [glam::Vec3; 8],
    len: usize,
}

impl Packet {
    fn push(&mut self, column: usize, origin: glam::Vec3, dir: glam::Vec3) {
        (self.columns[self.len], self.origins[self.len], self.dirs[self.len]) = (column, origin, dir);
        self.len += 1;
    }

    /// Traces the waiting segments and sets the bits of the visible ones in `words`.
    fn trace(&mut self, cs: &CpuScene, words: &mut [u64]) {
        if self.len == 0 {
            return;
        }
        let blocked = cs.rt.occluded8(&self.origins, &self.dirs, self.len, crate::SEGMENT_TNEAR, crate::SEGMENT_TFAR);
        for (k, &c) in self.columns[..self.len].iter().enumerate() {
            if blocked >> k & 1 == 0 {
                words[c / 64] |= 1u64 << (c % 64);
            }
        }
        self.len = 0;
    }
}

/// Fills the visibility matrix; returns it with the number of shadow rays traced.
pub fn visibility(cs: &CpuScene, rows: &[Endpoint], cols: &[Endpoint], progress: &dyn Progress) -> (BitMatrix, u64) {
    let mut m = BitMatrix::new(rows.len(), cols.len());
    if m.words_per_row == 0 {
        return (m, 0);
    }
    progress.start("visibility", rows.len() as u64);
    let rays: u64 = m
        .bits
        .par_chunks_mut(m.words_per_row)
        .zip(rows)
        .map(|(words, a)| {
            // A row's facing pairs go to Embree 8 at a time (rtcOccluded8): rays from one shading
            // point are coherent, and `make perf-report` measured packets at 0.85x the one-ray
            // loop's time on the Cornell box's rays.
            let mut packet = Packet::default();
            let mut rays = 0u64;
            for (c, b) in cols.iter().enumerate() {
                if facing(a, b) {
                    rays += 1;
                    let (o, d) = cs.shadow_segment(a.p(), a.n(), b.p(), b.n());
                    packet.push(c, o, d);
                    if packet.len == 8 {
                        packet.trace(cs, words);
                    }
                }
            }
            packet.trace(cs, words);
            progress.inc(1);
            rays
        })
        .sum();
    progress.finish();
    (m, rays)
}
