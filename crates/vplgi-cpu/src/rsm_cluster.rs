//! VPL clustering in reflective-shadow-map space (`--vpl-cluster rsm`, Prutkin et al. 2012,
//! Alg. 1 and section 4), the CPU reference.
//!
//! Each light's map is clustered on its own (a cluster never spans two lights), with K shared
//! among the maps by their VPLs (`vplgi_shared::rsm::clusters_per_map`). In a map of n × n texels
//! with k clusters:
//!
//! * **seeds**: point s = 1..=k of the 2-D Halton sequence (bases 2, 3) picks a texel, warped by
//!   the map's importance when it is given (Alg. 1 lines 5-7, `vplgi_shared::rsm_importance::warp`,
//!   which lands on texels with importance, so with VPLs); the seed is the first VPL at or after
//!   the texel in texel order (wrapping), so a seed always lands on a surface; two seeds on one
//!   VPL leave the second cluster empty;
//! * **assignment** (Alg. 1, line 14): each VPL takes the cluster of smallest μ (Eq. 1,
//!   `vplgi_shared::rsm::mu`; ties to the lower index) among the clusters whose map position lies
//!   in the ⌈√k⌉ × ⌈√k⌉ grid cells at most r = 2 cells from the VPL's own (5 × 5 cells); a VPL with
//!   no cluster there looks at all of the map's clusters;
//! * **sort** (lines 16-17): the VPL indices stably sorted by cluster, so each cluster's members
//!   are contiguous and in texel order;
//! * **update** (lines 18-21), over each cluster's contiguous members in that order: the centre
//!   and the normal are the flux-weighted means of the members' (weight: the flux summed over
//!   channels), the flux their sum, the map position their mean texel. A cluster left empty keeps
//!   its last state and takes part in no light.
//!
//! The iterations are `iterations` rounds of assignment and update, then a last assignment (and
//! its update: the states a next frame starts from); empty clusters are dropped and the rest
//! renumbered in order.
//!
//! **Warm start** (`--temporal on`, the paper's temporal coherence, Alg. 1 lines 8-12): the
//! previous frame's live clusters of each map take its first slots as they were
//! (`rsm::warm_slots`), and only the other slots are seeded, so clusters that emptied are
//! re-seeded by the importance map of the current frame. A cluster's representative (where its
//! light sits and its shadow rays end) is its member nearest the centre, ties to the lower index.

use crate::cluster::Clustering;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
pub use vplgi_shared::rsm::RsmClusterParams;
use vplgi_shared::rsm::{self, RsmCentre, RsmLight, RsmWeights, NEIGHBOURHOOD};
use vplgi_shared::rsm_importance;
use vplgi_types::{Vpl, MISS};
use crate::CpuScene;
use vplgi_frame::{ClusterCounts, FrameError, RsmStart};

/// One cluster's state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct State {
    centre: Vec3,
    normal: Vec3,
    chroma: Vec3,
    /// Position in the map, in texels.
    texel: Vec2,
}

impl From<RsmCentre> for State {
    fn from(c: RsmCentre) -> State {
        State { centre: c.centre.into(), normal: c.normal.into(), chroma: c.chroma.into(), texel: Vec2::new(c.texel_x, c.texel_y) }
    }
}

impl State {
    fn centre_of(&self, map: u32) -> RsmCentre {
        RsmCentre {
            centre: self.centre.to_array(),
            texel_x: self.texel.x,
            normal: self.normal.to_array(),
            texel_y: self.texel.y,
            chroma: self.chroma.to_array(),
            map,
        }
    }
}

/// One map's VPLs and clusters.
struct MapClusters<'a> {
    vpls: &'a [Vpl],
    map: &'a RsmLight,
    /// Grid cells per side.
    grid: i32,
    states: Vec<State>,
}

impl MapClusters<'_> {
    fn texel(&self, v: &Vpl) -> Vec2 {
        let k = v.path - self.map.first;
        Vec2::new((k % self.map.size) as f32 + 0.5, (k / self.map.size) as f32 + 0.5)
    }

    fn cell(&self, texel: Vec2) -> (i32, i32) {
        let f = self.grid as f32 / self.map.size as f32;
        (((texel.x * f) as i32).clamp(0, self.grid - 1), ((texel.y * f) as i32).clamp(0, self.grid - 1))
    }

    /// The cluster of smallest μ for VPL `v` among those near it (all of them if none is near).
    fn assign(&self, v: &Vpl, cells: &[Vec<u32>], w: &RsmWeights, inv_extent: f32) -> u32 {
        let (p, n, c) = (Vec3::from(v.position), Vec3::from(v.normal), rsm::chroma(Vec3::from(v.flux)));
        let score = |j: u32| {
            let s = &self.states[j as usize];
            (rsm::mu(w, (p - s.centre) * inv_extent, n, s.normal, c, s.chroma), j)
        };
        let (cx, cy) = self.cell(self.texel(v));
        let mut best = (f32::INFINITY, MISS);
        for y in (cy - NEIGHBOURHOOD).max(0)..=(cy + NEIGHBOURHOOD).min(self.grid - 1) {
            for x in (cx - NEIGHBOURHOOD).max(0)..=(cx + NEIGHBOURHOOD).min(self.grid - 1) {
                for &j in &cells[(y * self.grid + x) as usize] {
                    let cand = score(j);
                    if cand.0 < best.0 || (cand.0 == best.0 && cand.1 < best.1) {
                        best = cand;
                    }
                }
            }
        }
        if best.1 == MISS {
            for j in 0..self.states.len() as u32 {
                let cand = score(j);
                if cand.0 < best.0 || best.1 == MISS {
                    best = cand;
                }
            }
        }
        best.1
    }

    /// The clusters of each grid cell, by their map positions.
    fn cells(&self) -> Vec<Vec<u32>> {
        let mut cells = vec![Vec::new(); (self.grid * self.grid) as usize];
        for (j, s) in self.states.iter().enumerate() {
            let (x, y) = self.cell(s.texel);
            cells[(y * self.grid + x) as usize].push(j as u32);
        }
        cells
    }

    /// Alg. 1, lines 16-21: members sorted by cluster (stable, so in texel order), then each
    /// cluster's state from its contiguous members. Returns the member count of each cluster.
    fn update(&mut self, labels: &[u32]) -> Vec<u32> {
        let mut order: Vec<u32> = (0..self.vpls.len() as u32).collect();
        order.sort_by_key(|&i| labels[i as usize]);
        let mut counts = vec![0u32; self.states.len()];
        let mut start = 0;
        while start < order.len() {
            let label = labels[order[start] as usize];
            let end = start + order[start..].iter().take_while(|&&i| labels[i as usize] == label).count();
            let (mut weight, mut centre, mut normal, mut flux, mut texel) = (0.0f32, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec2::ZERO);
            for &i in &order[start..end] {
                let v = &self.vpls[i as usize];
                let f = Vec3::from(v.flux);
                let w = f.x + f.y + f.z;
                weight += w;
                centre += Vec3::from(v.position) * w;
                normal += Vec3::from(v.normal) * w;
                flux += f;
                texel += self.texel(v);
            }
            let s = &mut self.states[label as usize];
            let members = (end - start) as f32;
            if weight > 0.0 {
                s.centre = centre / weight;
            }
            s.normal = normal.try_normalize().unwrap_or(s.normal);
            s.chroma = rsm::chroma(flux);
            s.texel = texel / members;
            counts[label as usize] = (end - start) as u32;
            start = end;
        }
        counts
    }
}

/// The first VPL (an index into `vpls`, sorted by texel) at or after local texel `t` of `map`,
/// wrapping to the first.
fn vpl_at_or_after(vpls: &[Vpl], map: &RsmLight, t: u32) -> usize {
    let i = vpls.partition_point(|v| v.path < map.first + t);
    if i < vpls.len() {
        i
    } else {
        0
    }
}

/// Clusters `vpls` (from `rsm_vpls`, in texel order) of the maps `maps` in RSM space, its seeds
/// warped by `importance` (`rsm_importance`, one value per texel of the maps) if given.
pub fn rsm_cluster(vpls: &[Vpl], maps: &[RsmLight], params: &RsmClusterParams, importance: Option<&[f32]>) -> Clustering {
    rsm_cluster_from(vpls, maps, params, importance, None).clustering
}

/// A clustering and what a next frame starts from.
pub struct RsmClusters {
    pub clustering: Clustering,
    /// The live clusters' states after the last update, map by map.
    pub centres: Vec<RsmCentre>,
    /// Slots started from `previous` clusters, and slots seeded.
    pub kept: u32,
    pub fresh: u32,
}

/// [`rsm_cluster`], warm-started from the `previous` frame's live clusters if given.
pub fn rsm_cluster_from(vpls: &[Vpl], maps: &[RsmLight], params: &RsmClusterParams, importance: Option<&[f32]>, previous: Option<&[RsmCentre]>) -> RsmClusters {
    let empty = Clustering { f: 1, ..Default::default() };
    if vpls.is_empty() || params.k == 0 || maps.is_empty() {
        return RsmClusters { clustering: empty, centres: Vec::new(), kept: 0, fresh: 0 };
    }
    // The VPLs of each map: contiguous, since both are in texel order.
    let mut ranges = Vec::with_capacity(maps.len());
    for m in maps {
        let a = vpls.partition_point(|v| v.path < m.first);
        let b = vpls.partition_point(|v| v.path < m.first + m.size * m.size);
        ranges.push(a..b);
    }
    let per_map = rsm::clusters_per_map(&ranges.iter().map(|r| r.len() as u32).collect::<Vec<_>>(), params.k);
    let inv_extent = 1.0 / params.extent.max(f32::MIN_POSITIVE);
    let w = params.weights;
    let warm = rsm::warm_slots(previous.unwrap_or(&[]), &per_map);

    // Each map on its own; labels local to the map.
    let results: Vec<(Vec<u32>, Vec<State>, Vec<u32>)> = maps
        .iter()
        .zip(&ranges)
        .zip(&per_map)
        .zip(&warm)
        .map(|(((map, range), &k), warm)| {
            let vpls = &vpls[range.clone()];
            if k == 0 {
                return (Vec::new(), Vec::new(), Vec::new());
            }
            let grid = ((k as f64).sqrt().ceil() as i32).max(1);
            let mut mc = MapClusters { vpls, map, grid, states: Vec::with_capacity(k as usize) };
            let weights = importance.map(|imp| rsm_importance::map_weights(&imp[map.first as usize..(map.first + map.size * map.size) as usize], map.size, k));
            mc.states.extend(warm.iter().map(|c| State::from(*c)));
            for s in warm.len() as u32 + 1..=k {
                let warped = weights.as_ref().and_then(|(q, rows)| rsm_importance::warp(s, map.size, q, rows));
                let (x, y) = warped.unwrap_or_else(|| rsm::halton_texel(s, map.size));
                let t = y * map.size + x;
                let v = &vpls[vpl_at_or_after(vpls, map, t)];
                mc.states.push(State { centre: v.position.into(), normal: v.normal.into(), chroma: rsm::chroma(v.flux.into()), texel: mc.texel(v) });
            }
            let assign_all = |mc: &MapClusters| {
                let cells = mc.cells();
                mc.vpls.par_iter().map(|v| mc.assign(v, &cells, &w, inv_extent)).collect::<Vec<u32>>()
            };
            for _ in 0..params.iterations {
                let labels = assign_all(&mc);
                mc.update(&labels);
            }
            let labels = assign_all(&mc);
            let counts = mc.update(&labels);
            (labels, mc.states, counts)
        })
        .collect();

    // Drop the empty clusters, renumber the rest in order, and pick representatives.
    let mut out = Clustering { f: 1, ..empty };
    out.labels = vec![MISS; vpls.len()];
    out.weights = vec![1.0; vpls.len()];
    let mut centres = Vec::new();
    for (m, ((labels, states, counts), range)) in results.iter().zip(&ranges).enumerate() {
        let mut remap = vec![MISS; states.len()];
        for (j, s) in states.iter().enumerate() {
            if counts[j] > 0 {
                remap[j] = out.positions.len() as u32;
                out.positions.push(s.centre);
                out.normals.push(s.normal);
                out.members.push(counts[j]);
                out.representatives.push(MISS);
                centres.push(s.centre_of(m as u32));
            }
        }
        let mut best = vec![f32::INFINITY; out.positions.len()];
        for (local, &l) in labels.iter().enumerate() {
            let (i, g) = (range.start + local, remap[l as usize]);
            out.labels[i] = g;
            let d = Vec3::from(vpls[i].position).distance_squared(out.positions[g as usize]);
            if d < best[g as usize] {
                best[g as usize] = d;
                out.representatives[g as usize] = i as u32;
            }
        }
    }
    let kept = warm.iter().map(|w| w.len() as u32).sum::<u32>();
    RsmClusters { clustering: out, centres, kept, fresh: per_map.iter().sum::<u32>() - kept }
}

impl vplgi_frame::stages::RsmCluster for CpuScene<'_> {
    fn rsm_cluster(
        &self,
        vpls: &Vec<Vpl>,
        rsm_size: u32,
        params: &RsmClusterParams,
        start: RsmStart<'_, Vec<f32>>,
    ) -> Result<(Clustering, ClusterCounts, Vec<RsmCentre>), FrameError> {
        let r = rsm_cluster_from(vpls, &self.lights.rsm_maps(rsm_size), params, start.importance.map(|i| &i[..]), start.previous);
        let counts = ClusterCounts { kept: r.kept, fresh: r.fresh, ..Default::default() };
        Ok((r.clustering, counts, if start.carry { r.centres } else { Vec::new() }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_shared::rsm::point;

    /// A map of `n` × `n` texels, all hitting: VPLs on two walls meeting at a corner (left half
    /// of the map on the floor, facing up; right half on a wall rising from the floor's edge,
    /// facing -x), the floor red and the wall white.
    fn two_walls(n: u32) -> (Vec<Vpl>, RsmLight) {
        let map = RsmLight { size: n, ..point(Vec3::ZERO, Vec3::ONE) };
        let vpls = (0..n * n)
            .map(|t| {
                let (i, j) = ((t % n) as f32 / n as f32, (t / n) as f32 / n as f32);
                let (position, normal, flux) = if t % n < n / 2 {
                    (Vec3::new(i, 0.0, j), Vec3::Y, Vec3::new(1.0, 0.1, 0.1))
                } else {
                    (Vec3::new(0.5, i - 0.5, j), Vec3::NEG_X, Vec3::splat(0.5))
                };
                Vpl { position: position.to_array(), path: t, normal: normal.to_array(), bounce: 1, flux: (flux * 1e-3).to_array(), specular: 0, ..Default::default() }
            })
            .collect();
        (vpls, map)
    }

    fn params(k: u32) -> RsmClusterParams {
        RsmClusterParams { k, iterations: 6, weights: RsmWeights::default(), extent: 3f32.sqrt() }
    }

    /// With the paper's Cornell-box weights (w_n = 10), no cluster takes VPLs from both walls;
    /// every VPL has a cluster; the flux is conserved; the centres and normals are the members'
    /// flux-weighted means, recomputed here; representatives are members of their cluster.
    #[test]
    fn clusters_stay_on_one_wall_and_are_their_members_means() {
        let (vpls, map) = two_walls(32);
        let c = rsm_cluster(&vpls, &[map], &params(16), None);
        assert!(c.k() >= 12 && c.k() <= 16, "{} clusters", c.k());
        assert_eq!(c.members.iter().sum::<u32>(), vpls.len() as u32);
        for j in 0..c.k() {
            let members: Vec<&Vpl> = (0..vpls.len()).filter(|&i| c.hard_label(i) == j as u32).map(|i| &vpls[i]).collect();
            assert_eq!(members.len() as u32, c.members[j]);
            let normals: std::collections::BTreeSet<[i32; 3]> = members.iter().map(|v| v.normal.map(|x| x as i32)).collect();
            assert_eq!(normals.len(), 1, "cluster {j} spans both walls");
            let (mut w, mut x) = (0.0f64, [0.0f64; 3]);
            for v in &members {
                let f = (v.flux[0] + v.flux[1] + v.flux[2]) as f64;
                w += f;
                for (xa, pa) in x.iter_mut().zip(v.position) {
                    *xa += pa as f64 * f;
                }
            }
            let centre = Vec3::new((x[0] / w) as f32, (x[1] / w) as f32, (x[2] / w) as f32);
            assert!((c.positions[j] - centre).length() < 1e-5, "cluster {j}: {} vs {centre}", c.positions[j]);
            assert_eq!(c.normals[j], Vec3::from(members[0].normal));
            assert_eq!(c.hard_label(c.representatives[j] as usize), j as u32);
        }
    }

    /// The colour term splits a uniformly lit plane by flux colour: with w_Φ alone, a plane whose
    /// left half is red and right half green gets no cluster with both colours.
    #[test]
    fn the_colour_term_separates_colours() {
        let n = 24u32;
        let map = RsmLight { size: n, ..point(Vec3::ZERO, Vec3::ONE) };
        let vpls: Vec<Vpl> = (0..n * n)
            .map(|t| {
                let red = t % n < n / 2;
                let flux = if red { Vec3::X } else { Vec3::Y };
                Vpl {
                    position: [(t % n) as f32 / n as f32, 0.0, (t / n) as f32 / n as f32],
                    path: t,
                    normal: [0.0, 1.0, 0.0],
                    bounce: 1,
                    flux: flux.to_array(),
                    specular: 0,
                    ..Default::default()
                }
            })
            .collect();
        let p = RsmClusterParams { weights: RsmWeights { position: 1.0, normal: 0.0, flux: 10.0 }, ..params(9) };
        let c = rsm_cluster(&vpls, &[map], &p, None);
        for j in 0..c.k() as u32 {
            let colours: std::collections::BTreeSet<bool> = (0..vpls.len()).filter(|&i| c.hard_label(i) == j).map(|i| vpls[i].flux[0] > 0.0).collect();
            assert_eq!(colours.len(), 1, "cluster {j} mixes red and green");
        }
        // Without the colour term, position alone: some cluster straddles the colour edge.
        let p = RsmClusterParams { weights: RsmWeights { position: 1.0, normal: 0.0, flux: 0.0 }, ..params(9) };
        let c = rsm_cluster(&vpls, &[map], &p, None);
        let mixed = (0..c.k() as u32)
            .any(|j| (0..vpls.len()).filter(|&i| c.hard_label(i) == j).map(|i| vpls[i].flux[0] > 0.0).collect::<std::collections::BTreeSet<_>>().len() == 2);
        assert!(mixed, "the check above would pass without the colour term");
    }

    /// Two maps are clustered apart: K is shared by their VPLs, and no cluster has members of both.
    #[test]
    fn maps_are_clustered_apart() {
        let (mut a, ma) = two_walls(16);
        let (b, mb) = two_walls(8);
        let mb = RsmLight { first: 256, ..mb };
        a.extend(b.into_iter().map(|v| Vpl { path: v.path + 256, ..v }));
        let c = rsm_cluster(&a, &[ma, mb], &params(20), None);
        let first_b = (0..a.len()).filter(|&i| i >= 256).map(|i| c.hard_label(i)).min().unwrap();
        assert!((0..256).all(|i| c.hard_label(i) < first_b), "a cluster spans both maps");
        assert_eq!((first_b, c.k() as u32 - first_b), (16, 4), "K = 20 shared 256 : 64");
    }

    /// Importance-warped seeds spend the clusters where the importance is: with the floor's
    /// texels nine times as important as the wall's, about 9/10 of 16 clusters lie on the floor,
    /// where the plain Halton seeds put half.
    #[test]
    fn importance_moves_clusters_to_important_texels() {
        let (vpls, map) = two_walls(32);
        let importance: Vec<f32> = vpls.iter().map(|v| if v.normal[1] > 0.5 { 9.0 } else { 1.0 }).collect();
        let on_floor = |c: &Clustering| c.normals.iter().filter(|n| n.y > 0.5).count();
        let warped = rsm_cluster(&vpls, &[map], &params(16), Some(&importance));
        let plain = rsm_cluster(&vpls, &[map], &params(16), None);
        assert!(on_floor(&warped) >= 13, "{} of {} clusters on the floor", on_floor(&warped), warped.k());
        assert!(on_floor(&plain) <= 10, "{} of {} clusters on the floor without importance", on_floor(&plain), plain.k());
        assert_eq!(warped.members.iter().sum::<u32>(), vpls.len() as u32);
    }

    /// A converged clustering is a fixed point of the warm start: started from its own centres
    /// with no iteration, the next frame keeps every cluster, seeds none and labels every VPL
    /// alike. Slots the previous frame does not fill are seeded: a previous frame of 5 live
    /// clusters in a map of 16 slots keeps 5 and seeds 11, and centres of maps that no longer
    /// exist are ignored.
    #[test]
    fn warm_start_keeps_converged_clusters_and_seeds_the_rest() {
        let (vpls, map) = two_walls(32);
        let cold = rsm_cluster_from(&vpls, &[map], &RsmClusterParams { iterations: 40, ..params(16) }, None, None);
        assert_eq!((cold.kept, cold.fresh), (0, 16));
        assert_eq!(cold.centres.len(), cold.clustering.k());
        let warm = rsm_cluster_from(&vpls, &[map], &RsmClusterParams { iterations: 0, ..params(16) }, None, Some(&cold.centres));
        assert_eq!((warm.kept, warm.fresh), (cold.clustering.k() as u32, 16 - cold.clustering.k() as u32));
        assert_eq!(warm.clustering.labels, cold.clustering.labels);
        assert_eq!(warm.centres, cold.centres);

        let mut few = cold.centres[..5].to_vec();
        few.push(RsmCentre { map: 3, ..cold.centres[0] });
        let partial = rsm_cluster_from(&vpls, &[map], &params(16), None, Some(&few));
        assert_eq!((partial.kept, partial.fresh), (5, 11));
    }

    #[test]
    fn empty_inputs() {
        let (vpls, map) = two_walls(4);
        assert_eq!(rsm_cluster(&[], &[map], &params(4), None).k(), 0);
        assert_eq!(rsm_cluster(&vpls, &[map], &params(0), None).k(), 0);
        let c = rsm_cluster(&vpls, &[map], &params(1000), None);
        assert!(c.k() <= 16 && c.members.iter().sum::<u32>() == 16, "at most one cluster per VPL");
    }
}
