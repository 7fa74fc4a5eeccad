//! `bsdf`: the WGSL twin of the BSDFs (`shaders/common/bsdf.wgsl`) against
//! `vplgi_shared::bsdf` on the same random queries: eval, pdf and samples (SPEC, by the VPL row:
//! eval and pdf within `BSDF_REL`; at least `BSDF_AGREEING_SAMPLES` of samples from the same lobe
//! and within it).

use crate::tolerance::{Disagreement, BSDF_AGREEING_SAMPLES, BSDF_REL};
use crate::{count, result, v3, Plan, StageResult, Twins, VerifyError, VerifyStage};
use glam::{Vec2, Vec3};
use vplgi_gpu::bsdf::{bsdf_queries, BsdfAnswer, BsdfQuery};
use vplgi_shared::bsdf::{Bsdf, Transport};
use vplgi_types::{sampling, Rng, Stream};

/// |a - b| relative to the larger magnitude (absolute below 1e-6).
fn rel(a: f32, b: f32) -> f64 {
    ((a - b).abs() / a.abs().max(b.abs()).max(1e-6)) as f64
}

fn rel3(a: Vec3, b: Vec3) -> f64 {
    (0..3).map(|k| rel(a[k], b[k])).fold(0.0, f64::max)
}

/// `n` random queries of each of `models` (directions uniform on the sphere, from `seed`), on
/// both sides, samples weighted for radiance.
pub fn compare(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    models: &[Bsdf],
    n: usize,
    seed: u32,
) -> Result<Vec<Disagreement>, VerifyError> {
    let mut rng = Rng::new(seed, Stream::Oracle, 0);
    let mut dir = || sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
    let mut queries = Vec::with_capacity(models.len() * n);
    let mut numbers = Rng::new(seed, Stream::Oracle, 1);
    for b in models {
        for _ in 0..n {
            let (wi, wo) = (dir(), dir());
            let u = [numbers.next_f32(), numbers.next_f32(), numbers.next_f32()];
            queries.push(BsdfQuery {
                bsdf: b.record(),
                wi: wi.to_array(),
                wo: wo.to_array(),
                u,
                ..Default::default()
            });
        }
    }
    let answers = bsdf_queries(device, queue, &queries, true)?;
    let (mut value, mut value_at) = (0.0f64, None);
    let (mut sampled, mut sampled_at) = (0.0f64, None);
    let (mut diverged, mut samples) = (0usize, 0usize);
    for (i, (q, g)) in queries.iter().zip(&answers).enumerate() {
        let b = models[i / n];
        let (wi, wo) = (Vec3::from(q.wi), Vec3::from(q.wo));
        let (eval, pdf) = (b.eval(wi, wo), b.pdf(wi, wo));
        let d = rel3(eval, Vec3::from(g.eval)).max(rel(pdf, g.pdf));
        if d > value {
            value = d;
            value_at = Some(format!(
                "{b:?}, wi {}, wo {}: eval CPU {} GPU {}, pdf CPU {pdf:e} GPU {:e}",
                v3(q.wi),
                v3(q.wo),
                v3(eval.to_array()),
                v3(g.eval),
                g.pdf
            ));
        }
        let cpu = b.sample(wi, q.u[0], Vec2::new(q.u[1], q.u[2]), Transport::Radiance);
        let (made, delta) = (g.flags & 1 != 0, g.flags & 2 != 0);
        match cpu {
            None if !made => {}
            Some(s) if made && s.delta == delta && s.wo.z * g.wo[2] > 0.0 => {
                samples += 1;
                let d = rel3(s.weight, Vec3::from(g.weight))
                    .max(rel(s.pdf, g.sample_pdf))
                    .max((s.wo - Vec3::from(g.wo)).length() as f64);
                if d > BSDF_REL {
                    diverged += 1;
                }
                if d > sampled {
                    sampled = d;
                    sampled_at = Some(describe(&b, q, &s.wo, g));
                }
            }
            _ => {
                samples += 1;
                diverged += 1;
            }
        }
    }
    let case = format!("{} models x {} queries, seed {seed}", models.len(), count(n));
    let agree = 1.0 - diverged as f64 / samples.max(1) as f64;
    Ok(vec![
        Disagreement::at_most("bsdf", "eval and pdf: largest relative difference", value, BSDF_REL)
            .with_case(&case)
            .with_worst(value_at),
        Disagreement::at_least(
            "bsdf",
            "samples from the same lobe with direction, weight and pdf within the bound",
            agree,
            BSDF_AGREEING_SAMPLES,
        )
        .with_case(&case),
        Disagreement::info(
            "bsdf",
            "samples: largest difference of direction, weight, pdf (the diverging ones included)",
            sampled,
        )
        .with_case(&case)
        .with_worst(sampled_at),
    ])
}

fn describe(b: &Bsdf, q: &BsdfQuery, wo: &Vec3, g: &BsdfAnswer) -> String {
    format!(
        "{b:?}, wi {}, u {:?}: wo CPU {} GPU {}, weight GPU {}",
        v3(q.wi),
        q.u,
        v3(wo.to_array()),
        v3(g.wo),
        v3(g.weight)
    )
}

pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let mut r = result(VerifyStage::Bsdf);
    let models = Bsdf::every_kind(Vec3::new(0.9, 0.6, 0.3));
    r.checks = compare(twins.device(), twins.queue(), &models, 4096, plan.config.seed)?;
    r.notes.push(
        "Every BSDF kind on random directions of the whole sphere, both sides of the surface; \
         samples for radiance (refraction scales by the squared index ratio)."
            .into(),
    );
    Ok(r)
}
