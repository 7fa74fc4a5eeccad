//! `cluster` started from the previous frame's clusters (`--temporal on`) on the GPU, the twin
//! of `vplgi_cpu::cluster::temporal`: the admission of each point by its nearest previous centre
//! and each cluster's threshold for the next frame (`shaders/cluster_temporal.wgsl`). Read back:
//! the admitted count of each previous centre, each point's unfit flag, and the centres.

use super::{AssignRule, ClusterKernel, GpuClustering, Params};
use crate::buffers::{read_back, storage, storage_zeroed};
use crate::shader::{METRIC_EQ7, METRIC_WARD};
use crate::visibility::Endpoint;
use crate::GpuError;
use glam::Vec3;
use vplgi_types::clustering::Centre;
use vplgi_types::clustering::{GridGeometry, Metric};
use vplgi_types::FuzzyMode;

/// The metric's fields of [`Params`] for the passes that read it as data.
fn metric_params(metric: Metric, p: &mut Params) {
    match metric {
        Metric::Eq7 { normal_threshold } => (p.metric, p.threshold) = (METRIC_EQ7, normal_threshold),
        Metric::Ward { alpha } => (p.metric, p.alpha) = (METRIC_WARD, alpha),
    }
}

impl ClusterKernel {
    /// The previous centres that admit a point (increasing), and per point whether none does:
    /// each of the `m` points against its nearest previous centre on a grid of `geometry`.
    pub fn admit(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        geometry: &GridGeometry,
        (points, m): (&wgpu::Buffer, u32),
        previous: &[Centre],
        metric: Metric,
    ) -> Result<(Vec<u32>, Vec<bool>), GpuError> {
        let kp = previous.len() as u32;
        if kp == 0 {
            return Ok((Vec::new(), vec![true; m as usize]));
        }
        let centres: Vec<Endpoint> = previous.iter().map(|c| Endpoint::new(c.position, c.normal)).collect();
        let centres = storage(device, "previous centres", &centres);
        let thresholds = storage(device, "thresholds", &previous.iter().map(|c| c.threshold).collect::<Vec<f32>>());
        let grid = self.fill_grid(device, queue, geometry, &centres, kp)?;
        let nearest = self.assign(device, queue, &grid, (points, m), (&centres, kp), AssignRule { metric, f: 1, fuzzy: FuzzyMode::Hard })?;
        let admitted = storage_zeroed::<u32>(device, "admitted", kp as usize);
        let unfit = storage_zeroed::<u32>(device, "unfit", m as usize);
        for w in Self::windows(device, m, 1) {
            let mut p = Params { n: w.count as u32, k: kp, f: 1, ..Default::default() };
            metric_params(metric, &mut p);
            let b = [
                (1, w.of::<Endpoint>(points, 1)),
                (3, centres.as_entire_buffer_binding()),
                (4, admitted.as_entire_buffer_binding()),
                (5, thresholds.as_entire_buffer_binding()),
                (7, w.of::<u32>(&nearest.labels, 1)),
                (10, w.of::<u32>(&unfit, 1)),
            ];
            self.run_windows(device, queue, &self.admit, &p, &b, w.count as u32)?;
        }
        let admitted = read_back::<u32>(device, queue, &admitted, kp as usize)?;
        let unfit = read_back::<u32>(device, queue, &unfit, m as usize)?;
        Ok(((0..kp).filter(|&c| admitted[c as usize] > 0).collect(), unfit.iter().map(|&u| u != 0).collect()))
    }

    /// The clusters of `c` (over the `m` points) as the next frame's centres: each centroid with
    /// the largest metric key of its members by hard label.
    pub fn centres(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        c: &GpuClustering,
        (points, m): (&wgpu::Buffer, u32),
        metric: Metric,
    ) -> Result<Vec<Centre>, GpuError> {
        if c.k == 0 {
            return Ok(Vec::new());
        }
        let largest = storage_zeroed::<u32>(device, "largest keys", c.k as usize);
        for w in Self::windows(device, m, c.f) {
            let mut p = Params { n: w.count as u32, k: c.k, f: c.f, ..Default::default() };
            metric_params(metric, &mut p);
            let b = [
                (1, w.of::<Endpoint>(points, 1)),
                (3, c.centroids.as_entire_buffer_binding()),
                (4, largest.as_entire_buffer_binding()),
                (7, w.of::<u32>(&c.labels, c.f as u64)),
            ];
            self.run_windows(device, queue, &self.largest_key, &p, &b, w.count as u32)?;
        }
        let largest = read_back::<u32>(device, queue, &largest, c.k as usize)?;
        let centroids = read_back::<Endpoint>(device, queue, &c.centroids, c.k as usize)?;
        Ok(centroids
            .iter()
            .zip(largest)
            .map(|(e, bits)| Centre { position: Vec3::from(e.position), normal: Vec3::from(e.normal), threshold: f32::from_bits(bits) })
            .collect())
    }
}
