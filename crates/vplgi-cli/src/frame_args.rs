//! The frame options every rendering subcommand shares (`render`, `reference`, `sweep`, `bench`,
//! `verify`):
//! one `FrameArgs`, whose options are named after [`FrameConfig`]'s fields and override a preset.
//! Defaults are never typed here: `--help` shows the preset's values, read from [`FrameConfig`]
//! when the command line is built ([`document`]).

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;
use vplgi_shared::rsm::RsmWeights;
use vplgi_types::config::MAX_F;
use vplgi_types::{
    Caustics, ClusterMode, FrameConfig, FuzzyMode, Gi, LightShape, Lighting, Preset, RsmSeeding,
    Seeding, ShadeMode, SpMetric, SpRepresentative, Temporal, VplClustering, VplSource,
};

/// Options of one frame. Each is optional: what is not given comes from the preset. The field
/// names are [`FrameConfig`]'s, so the options overlay a configuration by name.
#[derive(Args, Clone, Debug, Default, Serialize)]
pub struct FrameArgs {
    /// Start from a named configuration: the paper's settings (section 4), its reference, or
    /// vplgi's default. Every option below overrides it; the defaults shown are where this
    /// subcommand starts without --preset.
    #[arg(long, value_enum)]
    #[serde(skip)]
    pub preset: Option<Preset>,
    /// Which point sets are clustered (the paper's ablation).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cluster: Option<ClusterMode>,
    /// How the visibility of a pixel's F shading-point clusters is combined.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fuzzy: Option<FuzzyMode>,
    /// Fuzziness F: shading-point clusters per shading point (ignored by --fuzzy hard).
    #[arg(short = 'F', value_parser = clap::value_parser!(u32).range(1..=MAX_F as i64))]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub f: Option<u32>,
    /// Number of shading-point clusters K_sp.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_sp: Option<u32>,
    /// Number of VPL clusters K_vpl.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_vpl: Option<u32>,
    /// Number of VPLs created (exactly, deterministically).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vpls: Option<u32>,
    /// VPLs at the first N surfaces a light particle hits (1 = direct light plus one indirect bounce).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    /// Image width in pixels.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub width: Option<u32>,
    /// Image height in pixels.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height: Option<u32>,
    /// Camera samples per pixel (> 1 jitters them; each is a shading point).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spp: Option<u32>,
    /// Mirrors and glass a camera ray follows, reflecting or refracting (chosen by Fresnel), to
    /// the first surface that is neither: that surface becomes the sample's shading point, seen
    /// through the chain's colour. Light particles and shadow-map texels pass as many between
    /// two surfaces that hold VPLs. After N of them the next surface is taken whatever it is
    /// (0: the first hit, a mirror shaded as if matte) [default: 6].
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specular_depth: Option<u32>,
    /// Caustics: the light that reaches surfaces straight from mirrors and glass (a caustic
    /// under a glass ball, a patch lit by a mirror). VPLs and shadow rays cannot carry it; with
    /// photons, light particles leave a photon wherever they leave a mirror or glass, and every
    /// shading point adds the density of its --caustic-k nearest (Jensen's caustic map). Needs
    /// --lighting all; nothing is traced in a scene without mirrors or glass.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caustics: Option<Caustics>,
    /// With --caustics photons: photons the caustic map holds (light particles are traced until
    /// it is full, or until 64 per photon have been).
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caustic_photons: Option<u32>,
    /// With --caustics photons: photons per density estimate (at most 128). More is smoother
    /// and blurs the caustic's edges more.
    #[arg(long, value_name = "K")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caustic_k: Option<u32>,
    /// With --caustics photons (and --gi photon's density estimates): the largest estimate
    /// radius, as a fraction of the scene's bounding-box diagonal (where fewer than K photons lie
    /// within it, it is the radius).
    #[arg(long, value_name = "FRACTION")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caustic_radius: Option<f32>,
    /// With --caustics photons or --gi photon: photons per leaf of a map's balanced kd-tree at
    /// most.
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub photon_leaf: Option<u32>,
    /// What carries the indirect light. vpl: virtual point lights and shadow rays (the core
    /// paper). photon: Wang et al. 2009's pipeline: light particles leave a photon at every
    /// non-specular surface (the global map); its kd-tree is cut where Eq. 3's estimate says
    /// the light has detail (--cut-size nodes, then --cut-refinements passes against the
    /// density estimate); at each shading-point cluster's representative --gather-rays cosine
    /// rays collect the light of the cut nodes around where they land (Eq. 4 and 5); every
    /// shading point interpolates. Needs --cluster sp or both with --shade interpolate; add
    /// --caustics photons in scenes with mirrors or glass. --preset photon sets all of it up as
    /// the paper does.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gi: Option<Gi>,
    /// With --gi photon: photons the global map holds.
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub global_photons: Option<u32>,
    /// With --gi photon: the illumination cut's target size in tree nodes; E_min is the mean
    /// estimate at the tree level of that many nodes (Wang et al. use 4096 and 8192).
    #[arg(long, value_name = "NODES")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_size: Option<u32>,
    /// With --gi photon: refinement passes of the cut (at most 8); each splits the nodes whose
    /// density estimate and Eq. 3 estimate differ by more than 1.2x the latter.
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_refinements: Option<u32>,
    /// With --gi photon: photons per density estimate at a cut node (2 to 128).
    #[arg(long, value_name = "K")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub photon_k: Option<u32>,
    /// Seed of every random decision; the same seed gives a bit-identical image.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u32>,
    /// Shadow-ray samples per shading point towards area lights (direct light).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direct_samples: Option<u32>,
    /// k-means downsampling factor gamma (Alg. 1).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gamma: Option<u32>,
    /// k-means iterations (Alg. 1).
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u32>,
    /// Normal threshold n_t of Eq. 7 (cosine; the default is cos 30°).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_threshold: Option<f32>,
    /// The shading points' clustering metric: the core paper's Eq. 7 (Euclidean distance,
    /// normals beyond --normal-threshold never share a cluster), or Eq. 2 of Wang et al. 2009
    /// (alpha |x - c| + sqrt(2 - 2 n.m), with --alpha; searched exactly).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub metric: Option<SpMetric>,
    /// alpha of Eq. 2 (Wang et al. 2009) per scene bounding-box diagonal, for --metric ward
    /// and --representative min-error: larger weighs position more against the normal (the
    /// paper uses 0.1 to 0.5 on a normalised scene).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f32>,
    /// Which member stands for a shading-point cluster (the shading point its visibility is
    /// traced from): the one nearest the centroid (the core paper), or the one of smallest
    /// Eq. 2 error, position and normal (Wang et al. 2009).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub representative: Option<SpRepresentative>,
    /// How the shading-point clustering picks its K initial centroids: evenly spread over the
    /// shading points (the core paper), or handed down a screen-space quadtree in proportion to
    /// each node's geometric variation under Eq. 2 with --alpha (Wang et al. 2009), so that
    /// corners and curved surfaces get more clusters than flat walls.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seeding: Option<Seeding>,
    /// Where clustered shading points' indirect light comes from: every shading point sums
    /// every VPL light through its F clusters' visibility (the core paper, Eq. 8-10), or the
    /// lights are summed only at each cluster's representative (its sample point) and every
    /// shading point interpolates the samples of its F nearest clusters with irradiance-caching
    /// weights (Wang et al. 2009); needs --cluster sp or both. With --gi vpl the samples hold
    /// irradiance alone, so a scene with rough metal, whose glossy light is not a multiple of
    /// the irradiance, is refused; --gi photon's samples carry spherical harmonics for it.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shade: Option<ShadeMode>,
    /// With --shade interpolate: cosine-distributed gather rays per sample point that measure
    /// R_j, the harmonic mean distance to what it sees (the interpolation weight's scale). With
    /// --gi photon the same rays are the final gather, which needs many more: Wang et al. use
    /// 250 to 500, --preset photon 256.
    #[arg(long)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gather_rays: Option<u32>,
    /// Which light the image holds: all of it, or only the indirect light of the VPLs (what
    /// clustering changes; a sequence's flicker is measured on it).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lighting: Option<Lighting>,
    /// In a sequence (render --frames): start each frame's clustering from the previous frame's
    /// clusters. Shading points (Wang et al. 2009): a cluster keeps the points within its
    /// members' largest error; clusters nobody fits are dropped, new ones are seeded where no
    /// cluster fits, and the iterations start from both. With --vpl-cluster rsm (Prutkin et al.
    /// 2012): the previous frame's live VPL clusters start the new clustering and only those that
    /// emptied are seeded again. Needs clusters to carry: --cluster sp or both, or --vpl-cluster
    /// rsm with --cluster vpl or both.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub temporal: Option<Temporal>,
    /// Geometry-term clamp: d_min as a fraction of the scene's bounding-box diagonal (0 = no clamp).
    #[arg(long = "g-clamp", allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub g_clamp_rel: Option<f32>,
    /// Put back the light the geometry-term clamp removes (Kollig and Keller's bias
    /// compensation: short segments from each shading point where the clamp bites, shaded in
    /// turn): the unclamped, unbiased transport, at the cost of extra shadow rays where surfaces
    /// are close. The paper's clustered settings keep the clamp as measured.
    #[arg(long, value_name = "true|false", action = clap::ArgAction::Set)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_compensation: Option<bool>,
    /// What a VPL cluster's light is: a point with the clamp (the core paper), or a disk sized by
    /// the members' spread and lit with no clamp, through the point-to-disk form factor of
    /// Prutkin et al. 2012 (Eq. 2) or through the exact form factor. Applies where VPLs are
    /// clustered (--cluster vpl or both).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_shape: Option<LightShape>,
    /// Where the VPLs come from: light paths through --bounces surfaces, or a reflective shadow
    /// map per light (Prutkin et al. 2012), one VPL per texel that hits a surface; rsm is
    /// single-bounce (--bounces 1).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vpl_source: Option<VplSource>,
    /// With --vpl-source rsm: the maps' texel budget, about N x N texels over all lights, each
    /// light's map sized by its share of the power.
    #[arg(long, value_name = "N")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rsm_size: Option<u32>,
    /// How VPLs are clustered: the core paper's k-means with Eq. 7, or Prutkin et al.'s
    /// k-means in shadow-map space with their Eq. 1 (each light's map on its own; needs
    /// --vpl-source rsm).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vpl_cluster: Option<VplClustering>,
    /// With --vpl-cluster rsm: Eq. 1's weights of position (squared distance in scene
    /// diagonals), normal (1 - cos) and flux colour. The paper uses 1,10,0 for the Cornell box
    /// (the default) and 1,1,10 for scenes with fine colour detail.
    #[arg(long, value_name = "WD,WN,WPHI", value_parser = parse_weights)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rsm_weights: Option<RsmWeights>,
    /// With --vpl-cluster rsm: where the clustering's seeds come from: Halton points spread
    /// evenly over each map, or (the paper's) the Halton points warped by the bidirectional
    /// importance map, each texel's flux times its geometry terms toward 256 pixels of the
    /// image, so clusters go where the camera sees their light.
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rsm_seeding: Option<RsmSeeding>,
}

/// `--rsm-weights 1,10,0`.
fn parse_weights(s: &str) -> Result<RsmWeights, String> {
    let w: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let [position, normal, flux] = w[..] else {
        return Err(format!("three comma-separated weights WD,WN,WPHI, got {}", w.len()));
    };
    let weights = RsmWeights { position, normal, flux };
    weights.validate()?;
    Ok(weights)
}

/// How a subcommand uses the frame options.
pub struct Use {
    pub command: &'static str,
    /// Where the options start from when `--preset` is not given.
    pub preset: Preset,
    /// Options the subcommand sets itself: hidden from its help and refused on its command line.
    pub fixed: &'static [&'static str],
    /// Why they are fixed (the error message).
    pub why: &'static str,
}

pub const RENDER: Use = Use { command: "render", preset: Preset::Default, fixed: &[], why: "" };
pub const REFERENCE: Use = Use {
    command: "reference",
    preset: Preset::Reference,
    fixed: &["preset"],
    why: "a reference starts from the unclustered reference preset (--cluster and the cluster counts make it the mean of a clustered configuration)",
};
pub const SWEEP: Use = Use {
    command: "sweep",
    preset: Preset::Default,
    fixed: &["preset", "cluster", "k_sp", "k_vpl", "temporal"],
    why: "the sweep sets them per configuration (--figure, --sp-clusters, --vpl-clusters; --figure flicker runs --temporal off and on)",
};
pub const BENCH: Use = Use {
    command: "bench",
    preset: Preset::Default,
    fixed: &["preset", "cluster", "k_sp", "k_vpl"],
    why: "the presets of --config set them; the other options override every preset",
};
pub const VERIFY: Use = Use { command: "verify", preset: Preset::Verify, fixed: &[], why: "" };
pub const USES: [Use; 5] = [RENDER, REFERENCE, SWEEP, BENCH, VERIFY];

impl FrameArgs {
    /// The options given, by [`FrameConfig`] field name.
    fn given(&self) -> Result<serde_json::Map<String, serde_json::Value>> {
        match serde_json::to_value(self).context("reading the frame options")? {
            serde_json::Value::Object(map) => Ok(map),
            _ => bail!("frame options are not a record"),
        }
    }

    /// The options laid over `base`.
    fn over(&self, base: &FrameConfig) -> Result<FrameConfig> {
        let mut config = serde_json::to_value(base).context("reading the frame configuration")?;
        if let serde_json::Value::Object(fields) = &mut config {
            fields.extend(self.given()?);
        }
        serde_json::from_value(config).context("applying the frame options")
    }

    /// The frame configuration of subcommand `u`: its preset (or `--preset`) with the options
    /// over it, checked.
    pub fn config(&self, u: &Use) -> Result<FrameConfig> {
        self.config_of(u, self.preset.unwrap_or(u.preset))
    }

    /// The options over `preset`, for subcommand `u`, checked.
    pub fn config_of(&self, u: &Use, preset: Preset) -> Result<FrameConfig> {
        let given = self.given()?;
        let mut fixed = u
            .fixed
            .iter()
            .filter(|id| given.contains_key(**id) || (**id == "preset" && self.preset.is_some()));
        if let Some(id) = fixed.next() {
            bail!("vplgi {} does not take {}: {}", u.command, flag(id), u.why);
        }
        let config = self.over(&preset.config())?;
        config.validate().map_err(|e| anyhow::anyhow!("invalid parameters: {e}"))?;
        Ok(config)
    }
}

/// How option `id` is written on the command line (`--k-sp`, `-F`, `--g-clamp`).
fn flag(id: &str) -> String {
    let cmd = <FrameArgs as Args>::augment_args(clap::Command::new("frame"));
    let arg = cmd.get_arguments().find(|a| a.get_id() == id);
    match (arg.and_then(|a| a.get_long()), arg.and_then(|a| a.get_short())) {
        (Some(long), _) => format!("--{long}"),
        (None, Some(short)) => format!("-{short}"),
        (None, None) => id.to_string(),
    }
}

/// A default as `--help` shows it: the frame's f32 fields reach here as f64, so a number is
/// written as the f32 it was (0.05, not 0.05000000074505806).
fn shown_default(value: &serde_json::Value) -> String {
    match value {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Number(n) if n.is_f64() => {
            n.as_f64().map_or_else(|| n.to_string(), |x| (x as f32).to_string())
        }
        v => v.to_string(),
    }
}

/// Adds each frame option's default (the subcommand's preset value) to its help, and hides the
/// options the subcommand fixes.
pub fn document(mut cmd: clap::Command) -> clap::Command {
    for u in USES {
        let defaults = match serde_json::to_value(u.preset.config()) {
            Ok(serde_json::Value::Object(map)) => map,
            _ => continue,
        };
        cmd = cmd.mut_subcommand(u.command, |mut sc| {
            for (id, value) in &defaults {
                if sc.get_arguments().any(|a| a.get_id() == id.as_str()) {
                    let shown = shown_default(value);
                    sc = sc.mut_arg(id.as_str(), |a| {
                        let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
                        a.help(format!("{help} [default: {shown}]"))
                    });
                }
            }
            for id in u.fixed {
                sc = sc.mut_arg(*id, |a| a.hide(true));
            }
            if u.command == REFERENCE.command {
                // A reference averages several seeds: --seed is the first (and was --first-seed).
                sc = sc.mut_arg("seed", |a| {
                    a.alias("first-seed").help(format!(
                        "The first seed: renders use seeds --seed, --seed + 1, ... [default: {}]",
                        u.preset.config().seed
                    ))
                });
            }
            sc
        });
    }
    cmd
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_override_the_preset_by_field_name() {
        let args = FrameArgs {
            width: Some(64),
            cluster: Some(ClusterMode::Sp),
            g_clamp_rel: Some(0.0),
            ..Default::default()
        };
        let c = args.config(&RENDER).unwrap();
        assert_eq!(
            (c.width, c.height, c.cluster, c.g_clamp_rel),
            (64, FrameConfig::default().height, ClusterMode::Sp, 0.0)
        );
        let high =
            FrameArgs { preset: Some(Preset::High), ..Default::default() }.config(&RENDER).unwrap();
        assert_eq!(high, FrameConfig::paper_high());
        assert_eq!(FrameArgs::default().config(&REFERENCE).unwrap(), FrameConfig::reference());
    }

    #[test]
    fn fixed_and_invalid_options_are_refused_by_name() {
        let e = FrameArgs { k_sp: Some(5), ..Default::default() }
            .config(&SWEEP)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--k-sp") && e.contains("the sweep sets them"), "{e}");
        let e = FrameArgs { preset: Some(Preset::High), ..Default::default() }
            .config(&SWEEP)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--preset"), "{e}");
        let e = FrameArgs { spp: Some(0), ..Default::default() }
            .config(&RENDER)
            .unwrap_err()
            .to_string();
        assert!(e.contains("spp"), "{e}");
    }
}
