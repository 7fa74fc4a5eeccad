//! Stage 1, `trace_vpls`: light particles leave the lights and leave a VPL at every
//! non-specular surface they hit, up to `bounces` surfaces (SPEC, "VPL tracing"). At mirrors and
//! glass they reflect or refract and go on, carrying the chain's weight: a VPL cannot stand for a
//! surface that scatters only along a delta direction. On rough metal the VPL keeps the
//! direction its light came from, which its glossy lobe depends on (`shade`), and the particle
//! goes on along the metal's own BSDF sample.
//!
//! Particle `i` emits from point i of the frame's scrambled Sobol' set and bounces with the
//! random stream (seed, `Stream::LightPath`, i), and uses nothing else, so its path does not
//! depend on which thread traces it. Particles are traced in index order in
//! parallel batches; the first particles whose VPLs reach the requested count are kept (the last
//! one's path cut short), so the VPL set is deterministic and exactly `count` long. Each VPL's
//! flux is divided by the number of particles used, which makes the VPL set an unbiased estimate
//! of the light leaving surfaces after 1..=`bounces` reflections.
//!
//! The same particles make the caustic photon map (`Deposit::CausticPhotons`): a photon where
//! a particle reaches a non-specular surface straight from a mirror or glass, with the power
//! that arrived. Those are the paths whose last step no VPL or shadow ray can follow. And they
//! make the global photon map of `--gi photon` (`Deposit::Photons`): a photon, with the power
//! that arrived, at every non-specular surface.

use crate::CpuScene;
use glam::{Vec2, Vec3};
use vplgi_shared::bsdf::Transport;
use rayon::prelude::*;
use vplgi_frame::Progress;
use vplgi_scene::lights::Emission;
use vplgi_types::{sampling, Deposit, Rng, Stream, Vpl};

use vplgi_types::params::MAX_SURVIVAL;
use vplgi_frame::FrameError;
use vplgi_types::TraceParams;

/// The VPLs of one frame.
#[derive(Clone, Debug, Default)]
pub struct VplSet {
    pub vpls: Vec<Vpl>,
    /// Number of light particles traced to make them (the estimator's sample count).
    pub particles: u32,
}

/// The digital shift of a frame's emission set: five draws of stream (seed, `Scramble`, 0).
pub fn emission_scramble(seed: u32) -> [u32; 5] {
    let mut rng = Rng::new(seed, Stream::Scramble, 0);
    std::array::from_fn(|_| rng.next_u32())
}

/// Traces light particle `index` through `bounces` non-specular surfaces and at most
/// `specular_depth` mirrors and glass between two of them, returning its VPLs (or caustic
/// photons, as `p.deposit` says) with flux not yet
/// divided by the particle count. Its emission (light choice, point, direction) is point `index` of a Sobol' set shared
/// by the frame's particles and shifted by `scramble` ([`emission_scramble`]): the particles
/// cover the lights' emission evenly instead of at random, so the VPLs, and the light they
/// stand for, vary less from seed to seed. Each particle's emission is still uniformly
/// distributed (the shift is random), so the estimate stays unbiased.
pub fn trace_particle(cs: &CpuScene, p: &TraceParams, scramble: [u32; 5], index: u32) -> Vec<Vpl> {
    match particle_emission(cs, scramble, index) {
        Some(emission) => follow_particle(cs, p, index, &emission),
        None => Vec::new(),
    }
}

/// Where light particle `index` leaves its light, in which direction and with what power.
pub fn particle_emission(cs: &CpuScene, scramble: [u32; 5], index: u32) -> Option<Emission> {
    // Direction in dimensions 1-2 (the best stratified pair), then light choice and point.
    let s = sampling::scrambled_sobol5(index, scramble);
    cs.lights.emit(cs.scene, [s[2], s[3], s[4], s[0], s[1]])
}

/// The VPLs of light particle `index` once it has left its light as `emission` says: what
/// [`trace_particle`] does after the emission, with the particle's own random stream.
pub fn follow_particle(cs: &CpuScene, p: &TraceParams, index: u32, emission: &Emission) -> Vec<Vpl> {
    let TraceParams { seed, bounces, specular_depth, .. } = *p;
    let mut rng = Rng::new(seed, Stream::LightPath, index);
    let mut vpls = Vec::new();
    let (mut origin, mut dir, mut power) = (emission.origin + emission.surface_normal * cs.eps, emission.dir, emission.power);
    // Specular vertices in a row, and in all.
    let (mut specular, mut passed) = (0, 0);
    let mut bounce = 1;
    while bounce <= bounces {
        let Some(hit) = cs.trace(origin, dir) else {
            break;
        };
        if specular < specular_depth && hit.bsdf().is_specular() {
            // Power, not radiance: a refraction's weight carries no η² (Veach's adjoint BSDF).
            let Some((out, weight)) = hit.scatter_specular(dir, rng.next_f32(), Transport::Importance) else {
                break;
            };
            power *= weight;
            specular += 1;
            passed += 1;
            dir = out;
            origin = cs.offset_toward(hit.position, hit.ng, hit.position + dir);
            continue;
        }
        let after_specular = specular > 0;
        specular = 0;
        let flux = power * hit.albedo;
        let deposit = match p.deposit {
            Deposit::Vpls => Some(flux),
            Deposit::CausticPhotons => after_specular.then_some(power),
            Deposit::Photons => Some(power),
        };
        if let Some(flux) = deposit {
            vpls.push(Vpl {
                position: hit.position.to_array(),
                path: index,
                normal: hit.ns.to_array(),
                bounce,
                flux: flux.to_array(),
                specular: passed,
                incoming: (-dir).to_array(),
                material: hit.material,
            });
        }
        if bounce == bounces {
            break;
        }
        if hit.surface.is_glossy() {
            // The BSDF's own sample, then Russian roulette on its weight (eval / pdf, which
            // carries the colour).
            let (u1, u) = (rng.next_f32(), Vec2::new(rng.next_f32(), rng.next_f32()));
            let Some((out, weight)) = hit.scatter(dir, u1, u, Transport::Importance) else {
                break;
            };
            let survive = weight.max_element().min(MAX_SURVIVAL);
            if survive <= 0.0 || rng.next_f32() >= survive {
                break;
            }
            power *= weight / survive;
            dir = out;
        } else {
            // Russian roulette on the albedo; cosine sampling makes the Lambertian weight
            // f cos / pdf equal to the albedo.
            let survive = hit.albedo.max_element().min(MAX_SURVIVAL);
            if survive <= 0.0 || rng.next_f32() >= survive {
                break;
            }
            power = flux / survive;
            dir = sampling::cosine_hemisphere(hit.ns, rng.next_f32(), rng.next_f32());
        }
        if dir.dot(hit.ng) <= 0.0 {
            // The shading normal let the direction dip under the surface.
            break;
        }
        origin = hit.position + hit.ng * cs.eps;
        bounce += 1;
    }
    vpls
}

/// Traces light particles until exactly `count` VPLs (or caustic photons) exist, or until a
/// particle budget of `64 * count + 65536` is spent, for scenes whose light mostly escapes or
/// seldom meets a mirror.
pub fn trace_vpls(cs: &CpuScene, p: &TraceParams, progress: &dyn Progress) -> VplSet {
    let TraceParams { seed, count, bounces, .. } = *p;
    let mut set = VplSet::default();
    if count == 0 || bounces == 0 || !cs.lights.has_lights() {
        return set;
    }
    let budget = (count as u64 * 64 + 65_536).min(u32::MAX as u64) as u32;
    let scramble = emission_scramble(seed);
    progress.start("trace_vpls", count as u64);
    let mut next = 0u32;
    let mut batch = count.clamp(1024, 1 << 16);
    'outer: while next < budget {
        let end = next.saturating_add(batch).min(budget);
        let paths: Vec<Vec<Vpl>> = (next..end).into_par_iter().map(|i| trace_particle(cs, p, scramble, i)).collect();
        for (offset, path) in paths.into_iter().enumerate() {
            set.particles = next + offset as u32 + 1;
            for v in path {
                set.vpls.push(v);
                if set.vpls.len() == count as usize {
                    break 'outer;
                }
            }
        }
        progress.set(set.vpls.len() as u64);
        next = end;
        // Size the next batch from the yield so far.
        let per_particle = (set.vpls.len() as f64 / set.particles.max(1) as f64).max(0.05);
        batch = (((count as usize - set.vpls.len()) as f64 / per_particle) as u32).clamp(1024, 1 << 20);
    }
    progress.finish();
    let inv = 1.0 / set.particles.max(1) as f32;
    for v in &mut set.vpls {
        v.flux = (Vec3::from(v.flux) * inv).to_array();
    }
    set
}

impl vplgi_frame::stages::TraceVpls for CpuScene<'_> {
    fn trace_vpls(&self, p: &TraceParams, progress: &dyn Progress) -> Result<(Vec<Vpl>, u32), FrameError> {
        let set = trace_vpls(self, p, progress);
        Ok((set.vpls, set.particles))
    }
}
