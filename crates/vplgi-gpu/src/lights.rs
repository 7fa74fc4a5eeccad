//! Light tables on the device: the host-built `vplgi_scene::lights::LightSampler`, uploaded, so
//! both backends choose lights with the same realised probabilities.

use crate::buffers::{kernel_params, storage};
use vplgi_scene::lights::LightSampler;
use vplgi_scene::{PunctualLight, Scene};
pub use vplgi_types::device::{Emitter, LightGroup, Punctual};
use vplgi_types::device::{PUNCTUAL_DIRECTIONAL, PUNCTUAL_POINT, PUNCTUAL_SPOT};

pub struct GpuLights {
    pub counts: wgpu::Buffer,
    pub emitters: wgpu::Buffer,
    pub area_table: wgpu::Buffer,
    pub all_table: wgpu::Buffer,
    pub punctual: wgpu::Buffer,
    pub groups: wgpu::Buffer,
    pub emitter_count: u32,
    pub punctual_count: u32,
}

fn table(d: &vplgi_scene::lights::Distribution) -> Vec<[f32; 2]> {
    d.cdf().iter().zip(d.pmfs()).map(|(&c, &p)| [c, p]).collect()
}

impl GpuLights {
    pub fn new(device: &wgpu::Device, scene: &Scene, sampler: &LightSampler) -> GpuLights {
        let emitters: Vec<Emitter> = sampler
            .emitters
            .iter()
            .zip(sampler.areas())
            .map(|(&t, &area)| {
                let [a, b, c] = scene.triangle(t as usize);
                let (e1, e2) = (b - a, c - a);
                let n = scene.geometric_normal(t as usize);
                let le = scene.emission(t as usize);
                Emitter {
                    v0: [a.x, a.y, a.z, area],
                    e1: [e1.x, e1.y, e1.z, 0.0],
                    e2: [e2.x, e2.y, e2.z, 0.0],
                    normal: [n.x, n.y, n.z, 0.0],
                    radiance: [le.x, le.y, le.z, 0.0],
                }
            })
            .collect();
        let punctual: Vec<Punctual> = sampler
            .punctual()
            .iter()
            .map(|l| match *l {
                PunctualLight::Point { position: p, intensity: i } => Punctual {
                    position: [p.x, p.y, p.z, PUNCTUAL_POINT],
                    direction: [0.0, 0.0, 1.0, 1.0],
                    intensity: [i.x, i.y, i.z, 0.0],
                },
                PunctualLight::Spot {
                    position: p,
                    direction: d,
                    intensity: i,
                    cos_inner,
                    cos_outer,
                } => Punctual {
                    position: [p.x, p.y, p.z, PUNCTUAL_SPOT],
                    direction: [d.x, d.y, d.z, cos_inner],
                    intensity: [i.x, i.y, i.z, cos_outer],
                },
                PunctualLight::Directional { direction: d, irradiance: e } => {
                    // The centre of the disk its particles start from, and the disk's radius.
                    let c = sampler.sun.disk_centre(d);
                    Punctual {
                        position: [c.x, c.y, c.z, PUNCTUAL_DIRECTIONAL],
                        direction: [d.x, d.y, d.z, sampler.sun.radius],
                        intensity: [e.x, e.y, e.z, 0.0],
                    }
                }
            })
            .collect();
        let counts =
            [emitters.len() as u32, punctual.len() as u32, sampler.groups().len() as u32, 0];
        GpuLights {
            counts: kernel_params(device, "light counts", &counts),
            emitters: storage(device, "emitters", &emitters),
            area_table: storage(device, "area table", &table(sampler.area_distribution())),
            all_table: storage(device, "all-light table", &table(sampler.all_distribution())),
            punctual: storage(device, "punctual lights", &punctual),
            groups: storage(device, "light groups", sampler.groups()),
            emitter_count: counts[0],
            punctual_count: counts[1],
        }
    }
}
