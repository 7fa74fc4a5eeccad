//! `shading_points`: the GPU's camera samples against the CPU's (SPEC: >= 99.9 % hit the same
//! triangle; positions within 1e-4 of the scene extent).

use crate::tolerance::{
    shading_points_emission_rays, shading_points_emission_rounding, shading_points_same_emission_share, Disagreement, CHAIN_CLASSES, SPECULAR_CHAIN_NUDGE,
    SHADING_POINTS_EMISSION_SUMS, SHADING_POINTS_POSITION_REL, SHADING_POINTS_SAME_SURFACE,
    SHADING_POINTS_UNREACHABLE_EMISSION,
};
use crate::map::{DisagreementMap, PointJudge};
use crate::segment::TieOracle;
use crate::{count, result, v3, StageResult, Twins, VerifyError, VerifyStage, Plan};
use glam::{DVec3, Vec3};
use vplgi_cpu::shading_points::{camera_path, sample_ray};
use vplgi_cpu::CpuScene;
use vplgi_scene::Scene;
use vplgi_types::sampling::orthonormal_basis;
use vplgi_types::{CameraParams, Rng, ShadingPoint, Stream, MISS};

/// How two backends' shading points of the same samples differ. Samples whose camera ray passed
/// a mirror or glass on either backend are counted apart ([`Chains`]).
#[derive(Clone, Debug, Default)]
pub struct HitDifferences {
    pub samples: usize,
    /// Of the unchained samples: the same triangle (or both missed).
    pub same: usize,
    /// Another triangle at the same point (within 1e-5 of the extent): a ray through an edge two
    /// triangles share may legitimately return either.
    pub ties: usize,
    /// Everything else: another surface, or a hit against a miss.
    pub other: usize,
    /// The first sample that differs beyond a tie, described.
    pub first_other: Option<String>,
    /// Largest position difference over the extent among unchained samples on the same
    /// triangle, and where.
    pub max_position: f32,
    pub max_position_at: Option<String>,
    /// The same, each difference times the cosine between the camera ray and the surface normal,
    /// and where. A ray that grazes a surface at angle theta to it slides along it by about
    /// 1 / sin theta times any rounding of its direction (CPU and GPU round the camera ray
    /// differently in the last bit): this is the disagreement with that slide divided out, the
    /// same as the raw one wherever rays meet surfaces at a sensible angle.
    pub max_position_conditioned: f32,
    pub max_position_conditioned_at: Option<String>,
    /// Of the samples on the same triangle (chained or not), those whose emitted radiance agrees
    /// (within 1e-6, relative above 1). Misses count too: at spp > 1 a sample's emission is its
    /// pixel's, from 4 x 4 extra rays, so a sample that misses may carry some, and one of those
    /// rays through a shared edge may see the emitter on one backend only (a step of 1/16).
    pub same_emission: usize,
    /// The samples on the same triangle, chained or not (what `same_emission` is a share of),
    /// but those in `emission_nudged`.
    pub same_any: usize,
    /// Pixel-centre samples through mirrors or glass on the same triangle whose emission differs
    /// where the CPU, its camera ray nudged ([`Nudge`]), sees the GPU's: the chain passed an
    /// edge between an emitter and another mirror on one side only. Set aside as ties.
    pub emission_nudged: usize,
    /// Largest emitted-radiance difference among the `same` samples that disagree, and where.
    pub max_emitted: f32,
    pub max_emitted_at: Option<String>,
    /// Samples through one specular vertex (the most either backend passed).
    pub one: Chains,
    /// Samples through two or more.
    pub longer: Chains,
}

impl HitDifferences {
    /// The share of unchained samples on the same surface point (the same triangle or an edge
    /// tie): what [`SHADING_POINTS_SAME_SURFACE`] bounds. 1 when every sample passed a mirror
    /// or glass: the chain rows judge them all.
    pub fn same_surface_share(&self) -> f64 {
        match self.same + self.ties + self.other {
            0 => 1.0,
            n => (self.same + self.ties) as f64 / n as f64,
        }
    }
}

/// Samples that followed specular chains of one length class.
#[derive(Clone, Debug, Default)]
pub struct Chains {
    pub samples: usize,
    /// Ending on another surface, beyond an edge tie and beyond a [`Nudge`].
    pub diverged: usize,
    /// Ending on another surface where the CPU, its camera ray nudged, ends where the GPU did.
    pub nudged: usize,
    /// Of those, the samples whose backends passed different numbers of specular vertices: a
    /// reflect-or-refract choice or a total internal reflection that went the other way.
    pub other_length: usize,
    pub first_diverged: Option<String>,
    /// Largest position difference over the extent among samples on the same triangle (a curved
    /// mirror, or an end at a grazing angle, magnifies a direction's rounding, so this is
    /// reported, not judged), and where.
    pub max_position: f32,
    pub max_position_at: Option<String>,
    /// Every such difference: their median is judged (see [`Chains::median_position`]).
    pub positions: Vec<f32>,
}

impl Chains {
    /// The median position difference over the extent among samples on the same triangle (0
    /// when none): held to the unchained samples' bound, which the rare magnified ones cannot
    /// move, while a kernel's error in a specular direction moves nearly all of them.
    pub fn median_position(&self) -> f32 {
        let mut p = self.positions.clone();
        p.sort_by(f32::total_cmp);
        p.get(p.len() / 2).copied().unwrap_or(0.0)
    }
}

fn describe(i: usize, width: u32, spp: u32, c: &ShadingPoint, g: &ShadingPoint) -> String {
    let px = i as u32 / spp;
    let show = |s: &ShadingPoint| {
        let seen = if s.is_miss() { "a miss".to_string() } else { format!("triangle {} at {}", s.triangle, v3(s.position)) };
        match s.specular {
            0 => seen,
            n => format!("{seen} through {n} specular"),
        }
    };
    format!("sample {i} (pixel {}, {}): CPU {}, GPU {}", px % width, px / width, show(c), show(g))
}

/// What the comparison reads off one sample's pair of shading points: [`hit_differences`] counts
/// it, and the stage's map colours it ([`crate::map::PointJudge`]).
pub(crate) struct PointPair {
    /// The same triangle (or both missed).
    pub same: bool,
    /// Another triangle at the same point (within 1e-5 of the extent): a ray through an edge two
    /// triangles share may legitimately return either.
    pub tie: bool,
    /// Position difference over the extent.
    pub apart: f32,
    /// The cosine between the camera ray and the CPU's normal ([`HitDifferences`] says why
    /// positions are judged times it).
    pub cos: f32,
    /// Largest emitted-radiance difference of a channel, and whether it is within 1e-6
    /// (relative above 1).
    pub emitted: f32,
    pub emission_agrees: bool,
}

impl PointPair {
    pub(crate) fn of(c: &ShadingPoint, g: &ShadingPoint, extent: f32, eye: Vec3) -> PointPair {
        let apart = (Vec3::from(c.position) - Vec3::from(g.position)).length() / extent;
        let same = c.triangle == g.triangle;
        let emitted = (Vec3::from(c.emitted) - Vec3::from(g.emitted)).abs().max_element();
        PointPair {
            same,
            tie: !same && !c.is_miss() && !g.is_miss() && apart <= 1e-5,
            apart,
            cos: Vec3::from(c.normal).dot((Vec3::from(c.position) - eye).normalize_or_zero()).abs(),
            emitted,
            emission_agrees: emitted <= 1e-6 * Vec3::from(c.emitted).max_element().max(1.0),
        }
    }
}

/// Whether a specular chain's divergence lies within rounding: the CPU traces the sample again
/// with its camera ray turned a little ([`SPECULAR_CHAIN_NUDGE`] says how far, and why) and
/// ends on the GPU's triangle through as many specular vertices, or misses as it did; or the
/// camera ray itself grazes an edge before its first hit (the f64 [`TieOracle`]), so that the
/// backends may start the chain on different triangles. A nudged ray cannot always stand for
/// the second: a camera centred in a square room sees the seams of floor and walls along the
/// image's diagonals, rays exactly through them, and where the wall is a mirror one backend
/// reflects at the floor's very edge and may pass below it, which no nudged ray repeats.
#[derive(Clone)]
pub struct Nudge<'a> {
    pub cs: &'a CpuScene<'a>,
    pub camera: CameraParams,
    /// The scene in f64, made at the first chain that parts: most comparisons have none, and the
    /// copy is the size of the scene.
    oracle: std::sync::Arc<std::sync::OnceLock<TieOracle>>,
}

impl<'a> Nudge<'a> {
    pub fn new(cs: &'a CpuScene<'a>, camera: CameraParams) -> Nudge<'a> {
        Nudge { cs, camera, oracle: Default::default() }
    }

    pub fn reaches(&self, sample: usize, gpu: &ShadingPoint) -> bool {
        self.grazes(sample)
            || self.paths(sample).any(|path| path.hit.map_or(MISS, |h| h.triangle) == gpu.triangle && path.specular == gpu.specular)
    }

    /// Whether the camera ray of `sample` grazes an edge (or meets one at its first hit) within
    /// the f64 oracle's tolerance.
    fn grazes(&self, sample: usize) -> bool {
        let (dir, _) = sample_ray(&self.camera, sample as u32);
        let o = self.camera.camera.position.as_dvec3();
        let reach = 4.0 * self.cs.extent as f64 + o.length();
        self.oracle.get_or_init(|| TieOracle::new(self.cs.scene)).ray_is_tie(o, dir.as_dvec3(), 0.0, reach)
    }

    /// Whether a nudged camera ray of pixel-centre sample `sample` ends on the GPU's triangle
    /// seeing the GPU's emitted radiance (within 1e-6, relative above 1).
    pub fn sees_emission(&self, sample: usize, gpu: &ShadingPoint) -> bool {
        let seen = Vec3::from(gpu.emitted);
        self.paths(sample).any(|path| {
            path.hit.map_or(MISS, |h| h.triangle) == gpu.triangle
                && (path.emitted - seen).abs().max_element() <= 1e-6 * seen.max_element().max(1.0)
        })
    }

    /// The CPU's camera paths of `sample` with its ray nudged.
    fn paths(&self, sample: usize) -> impl Iterator<Item = vplgi_cpu::shading_points::CameraPath> + '_ {
        let (dir, _) = sample_ray(&self.camera, sample as u32);
        nudged(dir).map(move |dir| {
            let mut chain = Rng::new(self.camera.seed, Stream::Specular, sample as u32);
            camera_path(self.cs, self.camera.camera.position, dir, self.camera.specular_depth, &mut chain)
        })
    }
}

/// `dir` turned by [`SPECULAR_CHAIN_NUDGE`], a tenth and a hundredth of it, each in 8 directions
/// around it.
pub(crate) fn nudged(dir: Vec3) -> impl Iterator<Item = Vec3> {
    let (u, v) = orthonormal_basis(dir);
    [1.0, 0.1, 0.01].into_iter().flat_map(move |scale| {
        (0..8).map(move |k| {
            let (sin, cos) = (k as f32 * std::f32::consts::FRAC_PI_4).sin_cos();
            (dir + (scale * SPECULAR_CHAIN_NUDGE) as f32 * (u * cos + v * sin)).normalize()
        })
    })
}

/// Classifies every sample's pair of shading points; `eye` is the camera's position. A chained
/// pair that parts is checked with `nudge` where given (the samples are `nudge`'s camera's).
pub fn hit_differences(
    cpu: &[ShadingPoint],
    gpu: &[ShadingPoint],
    extent: f32,
    eye: Vec3,
    (width, spp): (u32, u32),
    nudge: Option<&Nudge>,
) -> HitDifferences {
    let mut d = HitDifferences { samples: cpu.len(), ..Default::default() };
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        let PointPair { same, tie, apart, cos, emitted, emission_agrees } = PointPair::of(c, g, extent, eye);
        let chained = c.specular.max(g.specular) > 0;
        if same && !emission_agrees && chained && spp == 1 && nudge.is_some_and(|n| n.sees_emission(i, g)) {
            d.emission_nudged += 1;
        } else if same {
            d.same_any += 1;
            if emission_agrees {
                d.same_emission += 1;
            } else if emitted > d.max_emitted {
                d.max_emitted = emitted;
                d.max_emitted_at = Some(format!("{}: emitted CPU {}, GPU {}", describe(i, width, spp, c, g), v3(c.emitted), v3(g.emitted)));
            }
        }
        let chain = match c.specular.max(g.specular) {
            0 => None,
            1 => Some(&mut d.one),
            _ => Some(&mut d.longer),
        };
        if let Some(chain) = chain {
            chain.samples += 1;
            if same && !c.is_miss() {
                chain.positions.push(apart);
            }
            if same && !c.is_miss() && apart > chain.max_position {
                chain.max_position = apart;
                chain.max_position_at = Some(describe(i, width, spp, c, g));
            } else if !same && !tie && nudge.is_some_and(|n| n.reaches(i, g)) {
                chain.nudged += 1;
            } else if !same && !tie {
                chain.diverged += 1;
                chain.other_length += (c.specular != g.specular) as usize;
                chain.first_diverged.get_or_insert_with(|| describe(i, width, spp, c, g));
            }
            continue;
        }
        if same {
            d.same += 1;
            if c.is_miss() {
                continue;
            }
            if apart > d.max_position {
                d.max_position = apart;
                d.max_position_at = Some(describe(i, width, spp, c, g));
            }
            if apart * cos > d.max_position_conditioned {
                d.max_position_conditioned = apart * cos;
                d.max_position_conditioned_at = Some(format!("{} (cosine of incidence {cos:.2e})", describe(i, width, spp, c, g)));
            }
        } else if tie {
            d.ties += 1;
        } else {
            d.other += 1;
            d.first_other.get_or_insert_with(|| describe(i, width, spp, c, g));
        }
    }
    d.other += cpu.len().abs_diff(gpu.len());
    d
}

/// The emitted radiance a sample can carry whichever triangles its rays meet
/// ([`SHADING_POINTS_UNREACHABLE_EMISSION`]): `rays` times it is a sum of `rays` values, each the
/// emission of one of the scene's materials or 0.
pub struct EmissionSums {
    rays: u32,
    /// Every such sum, sorted by the sum of its channels.
    sums: Vec<DVec3>,
    /// How far, per channel, a sum added in f32 may be from the exact one.
    rounding: f64,
}

impl EmissionSums {
    /// The sums of `rays` of `scene`'s emission values; `Err` with the number of distinct
    /// emissions where the sums would number more than [`SHADING_POINTS_EMISSION_SUMS`].
    pub fn new(scene: &Scene, rays: u32) -> Result<EmissionSums, usize> {
        let mut values: Vec<Vec3> = scene.materials.iter().map(|m| m.emission).filter(|e| *e != Vec3::ZERO).collect();
        values.sort_by_key(|e| e.to_array().map(f32::to_bits));
        values.dedup();
        // C(rays + M, M), the multisets of at most `rays` of M values, stopping past the cap.
        let count = (1..=values.len() as u128).try_fold(1u128, |c, k| Some(c * (rays as u128 + k) / k).filter(|&c| c <= SHADING_POINTS_EMISSION_SUMS));
        if count.is_none() {
            return Err(values.len());
        }
        let values: Vec<DVec3> = values.iter().map(|e| e.as_dvec3()).collect();
        let mut sums = Vec::new();
        add_sums(&values, rays, DVec3::ZERO, &mut sums);
        sums.sort_by(|a, b| a.element_sum().total_cmp(&b.element_sum()));
        let largest = values.iter().map(|v| v.max_element()).fold(0.0, f64::max);
        Ok(EmissionSums { rays, sums, rounding: shading_points_emission_rounding(rays, largest) })
    }

    /// Whether `emitted` is the mean of `rays` of the scene's emission values, up to rounding
    /// (NaN and infinity never are).
    pub fn reaches(&self, emitted: [f32; 3]) -> bool {
        let t = Vec3::from(emitted).as_dvec3() * self.rays as f64;
        let (key, slack) = (t.element_sum(), 3.0 * self.rounding);
        let first = self.sums.partition_point(|s| s.element_sum() < key - slack);
        self.sums[first..].iter().take_while(|s| s.element_sum() <= key + slack).any(|s| (*s - t).abs().max_element() <= self.rounding)
    }
}

/// Every sum of `acc` and `left` more of `values`, each taken any number of times (0 included).
fn add_sums(values: &[DVec3], left: u32, acc: DVec3, out: &mut Vec<DVec3>) {
    match values.split_first() {
        None => out.push(acc),
        Some((v, rest)) => (0..=left).for_each(|k| add_sums(rest, left - k, acc + *v * k as f64, out)),
    }
}

/// The row of [`SHADING_POINTS_UNREACHABLE_EMISSION`]: the GPU's samples whose emitted radiance
/// the scene cannot give (the first described), or, where the scene has too many distinct
/// emissions to enumerate, how many it has (reported, not judged).
fn unreachable_emission(scene: &Scene, camera: &CameraParams, cpu: &[ShadingPoint], gpu: &[ShadingPoint]) -> Disagreement {
    let rays = shading_points_emission_rays(camera.spp);
    if rays > 1 && scene.has_specular() && camera.specular_depth > 0 {
        let what = "samples whose emitted radiance is no mean of the scene's emission values: not judged, as the pixel's rays may see emitters \
                    through mirrors and glass, scaled by their chains";
        return Disagreement::info("shading_points", what, 0.0);
    }
    let sums = match EmissionSums::new(scene, rays) {
        Ok(sums) => sums,
        Err(values) => {
            let what =
                format!("distinct emissions: too many for the per-sample emission row (more than {SHADING_POINTS_EMISSION_SUMS} sums of {rays}), not judged");
            return Disagreement::info("shading_points", what, values as f64);
        }
    };
    let what = if rays == 1 {
        "samples whose emitted radiance is none of the scene's emission values (or 0), of those seeing no mirror or glass".to_string()
    } else {
        format!("samples whose emitted radiance is no mean of {rays} of the scene's emission values (or 0)")
    };
    // A chained sample sees emission scaled by its chain: only the others are judged.
    let mut off = gpu.iter().enumerate().filter(|(_, g)| g.specular == 0 && !sums.reaches(g.emitted));
    let first = off.next().map(|(i, g)| {
        let px = i as u32 / camera.spp;
        let cpu = cpu.get(i).map_or("none".to_string(), |c| v3(c.emitted));
        format!("sample {i} (pixel {}, {}): GPU emitted {}, CPU {cpu}", px % camera.width, px / camera.width, v3(g.emitted))
    });
    let n = first.is_some() as usize + off.count();
    Disagreement::at_most("shading_points", what, n as f64, SHADING_POINTS_UNREACHABLE_EMISSION as f64).with_worst(first)
}

/// Chained samples on the same triangle a median position difference is judged over at least.
const MEDIAN_SAMPLES: usize = 100;

/// The shading points of `camera` on both backends.
pub fn both(twins: &Twins, camera: &CameraParams) -> Result<(Vec<ShadingPoint>, Vec<ShadingPoint>), VerifyError> {
    let cpu = vplgi_cpu::shading_points::shading_points(twins.cpu, camera);
    let gpu = twins.gpu.kernels().shading_points.run(twins.device(), twins.queue(), twins.gpu.scene(), camera, None)?;
    Ok((cpu, gpu))
}

/// Shades nothing: traces `camera`'s samples on both backends and compares them.
pub fn compare(twins: &Twins, camera: &CameraParams) -> Result<Vec<Disagreement>, VerifyError> {
    let (cpu, gpu) = both(twins, camera)?;
    Ok(compare_points(twins, camera, &cpu, &gpu))
}

/// How the maps judge a pair of shading points, as the rows below do; `camera` made them (a
/// chain that parts is then nudged).
pub fn judge<'a>(twins: &Twins<'a>, camera: Option<&CameraParams>) -> PointJudge<'a> {
    PointJudge {
        extent: twins.cpu.extent,
        eye: twins.scene.camera.position,
        position_bound: SHADING_POINTS_POSITION_REL,
        nudge: camera.map(|&camera| Nudge::new(twins.cpu, camera)),
    }
}

/// Compares both backends' shading points of `camera`'s samples.
fn compare_points(twins: &Twins, camera: &CameraParams, cpu: &[ShadingPoint], gpu: &[ShadingPoint]) -> Vec<Disagreement> {
    let nudge = Nudge::new(twins.cpu, *camera);
    let d = hit_differences(cpu, gpu, twins.cpu.extent, twins.scene.camera.position, (camera.width, camera.spp), Some(&nudge));
    let case = format!("{}x{}, {} spp", camera.width, camera.height, camera.spp);
    let mut albedo = 0.0f32;
    for (c, g) in cpu.iter().zip(gpu).filter(|(c, g)| c.triangle == g.triangle && !c.is_miss()) {
        albedo = albedo.max((Vec3::from(c.albedo) - Vec3::from(g.albedo)).abs().max_element());
    }
    let reachable = unreachable_emission(twins.scene, camera, cpu, gpu).with_case(&case);
    let mut rows = vec![
        Disagreement::at_least(
            "shading_points",
            "share of samples on the same surface point (of those seeing no mirror or glass)",
            d.same_surface_share(),
            SHADING_POINTS_SAME_SURFACE,
        )
        .with_case(&case)
        .with_worst(d.first_other.clone()),
        Disagreement::at_most(
            "shading_points",
            "position difference / scene extent, times the cosine of incidence",
            d.max_position_conditioned as f64,
            SHADING_POINTS_POSITION_REL,
        )
        .with_case(&case)
        .with_worst(d.max_position_conditioned_at.clone()),
        Disagreement::info("shading_points", "position difference / scene extent, raw (large only at grazing incidence)", d.max_position as f64)
            .with_case(&case)
            .with_worst(d.max_position_at.clone()),
        Disagreement::info("shading_points", "samples on another triangle at the same point (edge ties)", d.ties as f64).with_case(&case),
        Disagreement::info("shading_points", "largest albedo difference", albedo as f64).with_case(&case),
        // Emission otherwise reaches only the frame rows, where a 1 % error on an emitter's pixels
        // passed (relMSE far below the bound).
        Disagreement::at_least(
            "shading_points",
            "share of samples on the same triangle (or both missing) with the same emitted radiance",
            d.same_emission as f64 / d.same_any.max(1) as f64,
            shading_points_same_emission_share(camera.spp),
        )
        .with_case(&case)
        .with_worst(d.max_emitted_at.clone()),
        Disagreement::info("shading_points", "largest emitted-radiance difference among them", d.max_emitted as f64).with_case(&case),
        Disagreement::info(
            "shading_points",
            "samples through mirrors or glass on the same triangle with emission the CPU sees with its camera ray nudged (set aside as ties)",
            d.emission_nudged as f64,
        )
        .with_case(&case),
        // The share above lets 1.6 % of samples differ at spp > 1, more than the emitters' share
        // of the image: this row judges every sample's emission, so 1 % more fails at any spp.
        reachable,
    ];
    for ((label, bound), chains) in CHAIN_CLASSES.into_iter().zip([&d.one, &d.longer]) {
        if chains.samples == 0 {
            continue;
        }
        rows.push(crate::tolerance::share_of_diverged("shading_points", &format!("samples through {label} ending on another surface"), (chains.diverged, chains.samples), bound)
            .with_case(&case)
            .with_worst(chains.first_diverged.clone()));
        rows.push(
            Disagreement::info("shading_points", format!("of those through {label}: chains of another length (a Fresnel choice or total internal reflection)"), chains.other_length as f64)
                .with_case(&case),
        );
        rows.push(
            Disagreement::info(
                "shading_points",
                format!("samples through {label} ending on another surface that the CPU reaches with its camera ray nudged, or whose camera ray grazes an edge (f64) (set aside as ties)"),
                chains.nudged as f64,
            )
            .with_case(&case),
        );
        // A route through other mirrors to another point of one large triangle is a divergence
        // the triangle test misses; among a hundred samples or more, it cannot move the median.
        let what = format!("median position difference / scene extent through {label}, on the same triangle");
        let median = chains.median_position() as f64;
        rows.push(
            if chains.positions.len() >= MEDIAN_SAMPLES {
                Disagreement::at_most("shading_points", what, median, SHADING_POINTS_POSITION_REL)
            } else {
                Disagreement::info("shading_points", format!("{what} (of {}, fewer than {MEDIAN_SAMPLES}: not judged)", chains.positions.len()), median)
            }
            .with_case(&case),
        );
        rows.push(
            Disagreement::info("shading_points", format!("largest position difference / scene extent through {label}, on the same triangle"), chains.max_position as f64)
                .with_case(&case)
                .with_worst(chains.max_position_at.clone()),
        );
    }
    rows
}

/// The frame's camera samples.
pub fn verify(twins: &Twins, plan: &Plan) -> Result<StageResult, VerifyError> {
    let cfg = &plan.config;
    let mut r = result(VerifyStage::ShadingPoints);
    let camera = cfg.camera_params(twins.scene.camera);
    let (cpu, gpu) = both(twins, &camera)?;
    r.checks = compare_points(twins, &camera, &cpu, &gpu);
    let mut map = DisagreementMap::new(format!("shading_points-{}x{}-{}spp", camera.width, camera.height, camera.spp), camera.width, camera.height);
    map.mark_points(&cpu, &gpu, &judge(twins, Some(&camera)));
    r.maps.push(map);
    r.notes.push(format!(
        "{} samples; a ray through an edge shared by two triangles may return either (same point, another triangle): counted as agreement, and reported. \
         Positions are judged with each difference times the cosine between the camera ray and the surface: a ray grazing a surface slides along it by \
         1 / cosine times the last-bit rounding of its direction, which the backends do differently (make verify-long met a hit at cosine 1.9e-4, 1.06e-4 \
         of the extent apart); the raw difference is reported",
        count((cfg.width * cfg.height * cfg.spp) as usize)
    ));
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_scene::Material;
    use vplgi_types::{Rng, Stream};

    /// The Cornell box (one emission, E = (34, 24, 8)): j of 16 rays on the light is reached for
    /// every j, 1 % more or less of it is not, nor half a ray's worth, nor NaN; at one ray (spp
    /// 1), E and 0 only.
    #[test]
    fn one_emission_reaches_each_count_of_rays_and_nothing_one_percent_off() {
        let scene = vplgi_scene::cornell::cornell_box();
        let e = Vec3::new(34.0, 24.0, 8.0);
        assert!(scene.materials.iter().any(|m| m.emission == e), "the Cornell box's light changed: update this test");
        let sixteen = EmissionSums::new(&scene, 16).expect("one emission");
        for j in 0..=16 {
            let mean = (0..16).fold(Vec3::ZERO, |sum, k| sum + if k < j { e } else { Vec3::ZERO }) / 16.0;
            assert!(sixteen.reaches(mean.to_array()), "{j} rays of 16 on the light: {mean}");
            if j > 0 {
                for wrong in [mean * 1.01, mean * 0.99] {
                    assert!(!sixteen.reaches(wrong.to_array()), "{wrong}, 1 % off {j} rays of 16, is reached");
                }
            }
        }
        assert!(!sixteen.reaches((e / 32.0).to_array()) && !sixteen.reaches([f32::NAN; 3]) && !sixteen.reaches([f32::INFINITY; 3]));
        let one = EmissionSums::new(&scene, 1).expect("one emission");
        assert!(one.reaches(e.to_array()) && one.reaches([0.0; 3]));
        assert!(!one.reaches((e * 1.01).to_array()) && !one.reaches((e / 16.0).to_array()));
    }

    /// Three emissions that f32 cannot add exactly: 16 random picks (0 among them), added in f32
    /// in the order drawn as the kernels add them, are reached; 1 % more is not.
    #[test]
    fn sums_rounded_in_f32_are_reached() {
        let mut scene = vplgi_scene::cornell::cornell_box();
        for emission in [Vec3::new(0.1, 0.7, 1.3), Vec3::new(3.3, 0.3, 0.05)] {
            scene.materials.push(Material { name: "extra".into(), emission, ..Material::default() });
        }
        let values: Vec<Vec3> = [Vec3::ZERO].into_iter().chain(scene.materials.iter().map(|m| m.emission).filter(|e| *e != Vec3::ZERO)).collect();
        assert_eq!(values.len(), 4);
        let sums = EmissionSums::new(&scene, 16).expect("three emissions: 969 sums");
        let mut rng = Rng::new(5, Stream::Oracle, 0);
        for case in 0..1000 {
            let mean = (0..16).fold(Vec3::ZERO, |sum, _| sum + values[(rng.next_u32() % 4) as usize]) / 16.0;
            assert!(sums.reaches(mean.to_array()), "case {case}: {mean}");
            if mean != Vec3::ZERO {
                assert!(!sums.reaches((mean * 1.01).to_array()), "case {case}: 1 % more than {mean} is reached");
            }
        }
    }

    /// Too many distinct emissions: not enumerated.
    #[test]
    fn too_many_emissions_are_not_enumerated() {
        let mut scene = vplgi_scene::cornell::cornell_box();
        for i in 0..12 {
            scene.materials.push(Material { name: format!("e{i}"), emission: Vec3::splat(1.0 + i as f32), ..Material::default() });
        }
        assert_eq!(EmissionSums::new(&scene, 16).err(), Some(13));
        assert!(EmissionSums::new(&scene, 1).is_ok());
    }
}
