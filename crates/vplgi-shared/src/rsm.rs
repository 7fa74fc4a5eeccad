//! Reflective shadow maps (Dachsbacher and Stamminger 2005, as Prutkin et al. 2012 use them): the
//! first surfaces seen by rays on a regular grid over each light's emission, each texel a VPL
//! whose flux is the texel's power times the albedo where it lands.
//!
//! Every light has one square map of `size × size` texels, numbered after the previous maps'
//! (`first`), so a texel has one global index (a VPL's `path`). Its ray:
//!
//! * **area light** (one emissive triangle): direction by the cosine-weighted hemisphere map of
//!   the texel's centre, so every texel carries the same power π A L_e / size²; origin on the
//!   triangle at point k of the R2 low-discrepancy sequence (k = the texel's index in its map),
//!   so the map covers the whole emitter;
//! * **point light**: direction by the equal-area sphere map, power 4π I / size²;
//! * **spot light**: a perspective map over the square that holds the outer cone
//!   (tan θ_outer on each side), power I · falloff · (2 tan θ_outer / size)² cos³ θ, the
//!   intensity times the texel's solid angle; texels outside the outer cone send nothing;
//! * **directional light**: an orthographic map over the square of side 2R perpendicular to the
//!   light that holds the scene's bounding sphere (`vplgi_scene::lights::SunFrame`), every texel
//!   a parallel ray carrying E (2R / size)².
//!
//! Maps are sized by power ([`sized`]): a light with share s of the total gets about
//! `size · √s` texels per side, at least one.

use glam::Vec3;
use std::f32::consts::PI;
/// The records these functions work on, here too so one `use` reaches both.
pub use vplgi_types::rsm::*;
use vplgi_types::sampling;

/// The ray of one texel: where it starts, where it goes and the power it carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub power: Vec3,
    /// The emitting surface's normal (area lights; zero otherwise): the origin is pushed off it.
    pub surface_normal: Vec3,
}

/// The maps of `lights` sized for a budget of about `size²` texels: light i gets
/// `max(1, round(size √share_i))` texels per side, `shares` being each light's share of the
/// total power; maps are numbered in light order. Lights with no share keep no texel.
pub fn sized(lights: &[RsmLight], shares: &[f32], size: u32) -> Vec<RsmLight> {
    let mut first = 0u32;
    let mut out = Vec::with_capacity(lights.len());
    for (l, &share) in lights.iter().zip(shares) {
        if share.is_nan() || share <= 0.0 {
            continue;
        }
        let n = ((size as f32 * share.sqrt()).round() as u32).max(1);
        out.push(RsmLight { size: n, first, ..*l });
        first = first.saturating_add(n.saturating_mul(n));
    }
    out
}

/// Texels of all maps.
pub fn texel_count(maps: &[RsmLight]) -> u32 {
    maps.last().map_or(0, |m| m.first + m.size * m.size)
}

/// The map holding global texel `t` (maps in `first` order).
pub fn map_of(maps: &[RsmLight], t: u32) -> usize {
    maps.partition_point(|m| m.first <= t).saturating_sub(1)
}

/// Point `k` of the R2 sequence (Roberts' additive recurrence with the plastic constant), in
/// 32-bit fixed point so that every backend computes the same bits: two numbers in [0, 1).
pub fn r2_point(k: u32) -> (f32, f32) {
    // round(2^32 / g) and round(2^32 / g²), g the plastic number 1.3247...
    const A1: u32 = 3_242_174_889;
    const A2: u32 = 2_447_445_414;
    let x = k.wrapping_mul(A1).wrapping_add(1 << 31);
    let y = k.wrapping_mul(A2).wrapping_add(1 << 31);
    ((x >> 8) as f32 * (1.0 / 16_777_216.0), (y >> 8) as f32 * (1.0 / 16_777_216.0))
}

/// The spot falloff of glTF (`vplgi_scene::PunctualLight::falloff_cos`): 1 inside the inner
/// cone, 0 outside the outer one, a quadratic ramp between.
pub fn spot_falloff(cos_axis: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
    let t = ((cos_axis - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// The ray of texel `t` of `map` (`map.first <= t < map.first + size²`), or `None` for a spot
/// texel outside the outer cone.
pub fn texel_ray(map: &RsmLight, t: u32) -> Option<TexelRay> {
    let n = map.size;
    let k = t - map.first;
    let (i, j) = (k % n, k / n);
    let inv = 1.0 / n as f32;
    let (u, v) = ((i as f32 + 0.5) * inv, (j as f32 + 0.5) * inv);
    let texels = (n * n) as f32;
    let origin = Vec3::from(map.origin);
    let axis = Vec3::from(map.axis);
    let power = Vec3::from(map.power);
    match map.kind {
        RSM_AREA => {
            let (r1, r2) = r2_point(k);
            let (b1, b2) = sampling::uniform_triangle(r1, r2);
            let p = origin + Vec3::from(map.e1) * b1 + Vec3::from(map.e2) * b2;
            Some(TexelRay {
                origin: p,
                dir: sampling::cosine_hemisphere(axis, u, v),
                power: power / texels,
                surface_normal: axis,
            })
        }
        RSM_POINT => Some(TexelRay {
            origin,
            dir: sampling::uniform_sphere(u, v),
            power: power / texels,
            surface_normal: Vec3::ZERO,
        }),
        RSM_DIRECTIONAL => {
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let (e1, e2) = (Vec3::from(map.e1), Vec3::from(map.e2));
            // The texel's area: (2R / n)², R = |e1|.
            let side = 2.0 * inv;
            Some(TexelRay {
                origin: origin + e1 * x + e2 * y,
                dir: axis,
                power: power * (side * side * e1.length_squared()),
                surface_normal: Vec3::ZERO,
            })
        }
        _ => {
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let (e1, e2) = (Vec3::from(map.e1), Vec3::from(map.e2));
            let d = axis + e1 * x + e2 * y;
            let len2 = 1.0 + (x * x) * e1.length_squared() + (y * y) * e2.length_squared();
            let cos = 1.0 / len2.sqrt();
            let falloff = spot_falloff(cos, map.cos_inner, map.cos_outer);
            if falloff <= 0.0 {
                return None;
            }
            // The texel's solid angle: its area on the plane at distance 1, (2 tan / n)², times
            // cos³ θ (cos θ for the tilt, 1 / r² = cos² θ for the distance).
            let side = 2.0 * inv;
            let omega = side * side * e1.length_squared() * cos * cos * cos;
            Some(TexelRay {
                origin,
                dir: d * cos,
                power: power * (falloff * omega),
                surface_normal: Vec3::ZERO,
            })
        }
    }
}

/// The map of a spot light at `position` pointing along unit `direction`.
pub fn spot(
    position: Vec3,
    direction: Vec3,
    intensity: Vec3,
    cos_inner: f32,
    cos_outer: f32,
) -> RsmLight {
    let (right, up) = sampling::orthonormal_basis(direction);
    let cos_outer = cos_outer.clamp(-1.0, 1.0);
    // A perspective map cannot hold a cone of 90 degrees or more: it is cut at 89.
    let tan = (1.0 - cos_outer * cos_outer).max(0.0).sqrt() / cos_outer.max(0.017_452_4);
    RsmLight {
        origin: position.to_array(),
        kind: RSM_SPOT,
        e1: (right * tan).to_array(),
        e2: (up * tan).to_array(),
        axis: direction.to_array(),
        cos_inner,
        cos_outer,
        power: intensity.to_array(),
        ..Default::default()
    }
}

/// The map of a directional light travelling along unit `direction`: the square of half side
/// `half_side` around `centre`, perpendicular to it, with irradiance `irradiance`.
pub fn directional(centre: Vec3, direction: Vec3, half_side: f32, irradiance: Vec3) -> RsmLight {
    let (right, up) = sampling::orthonormal_basis(direction);
    RsmLight {
        origin: centre.to_array(),
        kind: RSM_DIRECTIONAL,
        e1: (right * half_side).to_array(),
        e2: (up * half_side).to_array(),
        axis: direction.to_array(),
        power: irradiance.to_array(),
        ..Default::default()
    }
}

/// The map of a point light.
pub fn point(position: Vec3, intensity: Vec3) -> RsmLight {
    RsmLight {
        origin: position.to_array(),
        kind: RSM_POINT,
        power: (intensity * (4.0 * PI)).to_array(),
        ..Default::default()
    }
}

/// The map of an emissive triangle (vertices `a`, `b`, `c`, unit normal `normal`, emitted
/// radiance `radiance`).
pub fn area(a: Vec3, b: Vec3, c: Vec3, normal: Vec3, radiance: Vec3) -> RsmLight {
    let area = 0.5 * (b - a).cross(c - a).length();
    RsmLight {
        origin: a.to_array(),
        kind: RSM_AREA,
        e1: (b - a).to_array(),
        e2: (c - a).to_array(),
        axis: normal.to_array(),
        power: (radiance * (PI * area)).to_array(),
        ..Default::default()
    }
}

/// Where each map's clusters start: `previous`'s live clusters of map m (in their order) fill
/// its first slots, at most `k[m]` of them; the other slots are seeded. Returns, per map, the
/// states of its first slots.
pub fn warm_slots(previous: &[RsmCentre], k: &[u32]) -> Vec<Vec<RsmCentre>> {
    let mut slots: Vec<Vec<RsmCentre>> = vec![Vec::new(); k.len()];
    for c in previous {
        if let Some(s) = slots.get_mut(c.map as usize) {
            if (s.len() as u32) < k[c.map as usize] {
                s.push(*c);
            }
        }
    }
    slots
}

/// Φ / |Φ| (the RGB vector's Euclidean norm): hue and saturation without brightness; 0 for black.
pub fn chroma(flux: Vec3) -> Vec3 {
    let len = flux.length();
    if len > 0.0 {
        flux / len
    } else {
        Vec3::ZERO
    }
}

/// Eq. 1: μ(p, c) = w_d |x_p − x_c|² + w_n (1 − n_p · n_c) + w_Φ |Φ_p/|Φ_p| − Φ_c/|Φ_c||², with
/// `dx` = (x_p − x_c) / the scene's diagonal and the colours already [`chroma`].
pub fn mu(w: &RsmWeights, dx: Vec3, np: Vec3, nc: Vec3, chroma_p: Vec3, chroma_c: Vec3) -> f32 {
    let dc = chroma_p - chroma_c;
    w.position * dx.dot(dx) + w.normal * (1.0 - np.dot(nc)) + w.flux * dc.dot(dc)
}

/// Digits of the Halton points behind [`halton_texel`]: 20 in base 2, 12 in base 3 (3^12 <
/// 2^20), so that a coordinate times a map side of at most 4096 fits 32 bits.
const HALTON_BITS: u32 = 20;
const HALTON_3_DIGITS: u32 = 12;
const THREE_TO_THE_DIGITS: u32 = 531_441;

/// The texel (x, y) of an `n` × `n` map under point `i` of the 2-D Halton sequence (the van der
/// Corput sequences in bases 2 and 3), floor(n · h), in integer arithmetic only, so that every
/// backend picks the same texel. The points keep their first 20 binary and 12 ternary digits
/// (distinct for i < 531,441).
pub fn halton_texel(i: u32, n: u32) -> (u32, u32) {
    let x2 = i.reverse_bits() >> (32 - HALTON_BITS);
    let (mut x3, mut j) = (0u32, i);
    for _ in 0..HALTON_3_DIGITS {
        x3 = x3 * 3 + j % 3;
        j /= 3;
    }
    (
        ((x2 as u64 * n as u64) >> HALTON_BITS) as u32,
        (x3 as u64 * n as u64 / THREE_TO_THE_DIGITS as u64) as u32,
    )
}

/// K clusters shared among maps in proportion to their VPLs: map m gets round(K v_m / V),
/// at least 1 if it has a VPL and at most its VPL count.
pub fn clusters_per_map(vpls_per_map: &[u32], k: u32) -> Vec<u32> {
    let total: u64 = vpls_per_map.iter().map(|&v| v as u64).sum();
    vpls_per_map
        .iter()
        .map(|&v| {
            if v == 0 || total == 0 {
                0
            } else {
                ((k as f64 * v as f64 / total as f64).round() as u32).clamp(1, v)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Element `i` (from 1) of the van der Corput sequence in `base`, in double precision: the
    /// oracle of [`halton_texel`].
    fn halton(mut i: u32, base: u32) -> f32 {
        let (mut f, mut r) = (1.0f64, 0.0f64);
        while i > 0 {
            f /= base as f64;
            r += f * (i % base) as f64;
            i /= base;
        }
        r as f32
    }

    /// Eq. 1 on hand-checked values: unit weights, positions 0.3 apart along x, normals 60
    /// degrees apart (1 - cos = 0.5), pure red against pure green (|(1,0,0) - (0,1,0)|² = 2).
    #[test]
    fn eq_1_on_a_hand_checked_pair() {
        let n60 = Vec3::new(0.0, 0.75f32.sqrt(), 0.5);
        let (red, green) = (chroma(Vec3::new(4.0, 0.0, 0.0)), chroma(Vec3::new(0.0, 0.2, 0.0)));
        assert_eq!((red, green), (Vec3::X, Vec3::Y));
        let w = RsmWeights { position: 1.0, normal: 1.0, flux: 1.0 };
        let m = mu(&w, Vec3::new(0.3, 0.0, 0.0), Vec3::Z, n60, red, green);
        assert!((m - (0.09 + 0.5 + 2.0)).abs() < 1e-6, "{m}");
        // Each weight scales its own term only.
        let w = RsmWeights { position: 10.0, normal: 0.0, flux: 0.5 };
        assert!(
            (mu(&w, Vec3::new(0.3, 0.0, 0.0), Vec3::Z, n60, red, green) - (0.9 + 1.0)).abs() < 1e-6
        );
        // Brightness does not count, colour does.
        assert_eq!(chroma(Vec3::new(1.0, 2.0, 2.0)), chroma(Vec3::new(3.0, 6.0, 6.0)));
        assert_eq!(chroma(Vec3::ZERO), Vec3::ZERO);
    }

    #[test]
    fn weights_are_checked() {
        assert_eq!(RsmWeights::default().validate(), Ok(()));
        assert!(RsmWeights { position: -1.0, ..Default::default() }
            .validate()
            .unwrap_err()
            .contains(">= 0"));
        assert!(RsmWeights { flux: f32::NAN, ..Default::default() }
            .validate()
            .unwrap_err()
            .contains("finite"));
        assert!(RsmWeights { position: 0.0, normal: 0.0, flux: 0.0 }
            .validate()
            .unwrap_err()
            .contains("all be 0"));
    }

    #[test]
    fn halton_and_the_cluster_shares() {
        let h2: Vec<f32> = (1..=4).map(|i| halton(i, 2)).collect();
        let h3: Vec<f32> = (1..=4).map(|i| halton(i, 3)).collect();
        assert_eq!(h2, [0.5, 0.25, 0.75, 0.125]);
        assert_eq!(h3, [1.0 / 3.0, 2.0 / 3.0, 1.0 / 9.0, 4.0 / 9.0]);
        for n in [1u32, 7, 128, 4096] {
            for i in 1..2000u32 {
                let (x, y) = halton_texel(i, n);
                let (fx, fy) = (
                    (halton(i, 2) as f64 * n as f64).floor() as u32,
                    (halton(i, 3) as f64 * n as f64).floor() as u32,
                );
                // The truncated digits can only move a point down across a texel edge.
                assert!(
                    x == fx && (y == fy || y + 1 == fy),
                    "i {i}, n {n}: ({x}, {y}) vs ({fx}, {fy})"
                );
                assert!(x < n && y < n);
            }
        }
        assert_eq!(clusters_per_map(&[300, 100, 0, 1], 8), vec![6, 2, 0, 1]);
        assert_eq!(clusters_per_map(&[5], 100), vec![5], "never more clusters than VPLs");
        assert_eq!(clusters_per_map(&[0, 0], 10), vec![0, 0]);
    }

    fn sized_one(l: RsmLight, n: u32) -> RsmLight {
        sized(&[l], &[1.0], n)[0]
    }

    #[test]
    fn maps_are_sized_by_power_and_numbered_in_order() {
        let l = point(Vec3::ZERO, Vec3::ONE);
        let maps = sized(&[l, l, l, l], &[0.64, 0.0, 0.36, 1e-9], 100);
        let sizes: Vec<(u32, u32)> = maps.iter().map(|m| (m.size, m.first)).collect();
        assert_eq!(sizes, vec![(80, 0), (60, 6400), (1, 10_000)]);
        assert_eq!(texel_count(&maps), 10_001);
        assert_eq!(
            [map_of(&maps, 0), map_of(&maps, 6399), map_of(&maps, 6400), map_of(&maps, 10_000)],
            [0, 0, 1, 2]
        );
        assert_eq!(texel_count(&[]), 0);
    }

    #[test]
    fn area_and_point_maps_carry_exactly_the_lights_power() {
        // Off the origin, so that the area comes from the edges, not the corners.
        let o = Vec3::new(0.5, 1.0, -2.0);
        let a = area(o, o + Vec3::X * 2.0, o + Vec3::Z * 3.0, Vec3::Y, Vec3::new(1.0, 2.0, 3.0));
        // π A L_e with A = 3.
        assert!(
            (Vec3::from(a.power) - Vec3::new(1.0, 2.0, 3.0) * 3.0 * PI).abs().max_element() < 1e-5
        );
        for l in [a, point(Vec3::ONE, Vec3::splat(0.5))] {
            let m = sized_one(l, 37);
            let total: Vec3 =
                (0..37 * 37).map(|t| texel_ray(&m, t).expect("every texel emits").power).sum();
            assert!(
                (total - Vec3::from(l.power)).abs().max_element()
                    <= 1e-4 * Vec3::from(l.power).max_element(),
                "{total}"
            );
        }
    }

    /// An area map's rays start on the triangle and leave its front side with the cosine
    /// distribution: the mean cosine of a cosine-weighted hemisphere is 2/3, the mean of the
    /// origins' barycentrics 1/3 each (the R2 points are uniform on the triangle).
    #[test]
    fn area_rays_start_on_the_emitter_and_leave_its_front() {
        let (a, b, c) =
            (Vec3::new(1.0, 2.0, 0.0), Vec3::new(3.0, 2.0, 0.0), Vec3::new(1.0, 2.0, -2.0));
        let m = sized_one(area(a, b, c, Vec3::Y, Vec3::ONE), 64);
        let (mut cos, mut centre) = (0.0f64, Vec3::ZERO);
        for t in 0..64 * 64 {
            let r = texel_ray(&m, t).expect("emits");
            assert!(r.dir.dot(Vec3::Y) > 0.0 && (r.dir.length() - 1.0).abs() < 1e-5);
            assert!(
                (r.origin.y - 2.0).abs() < 1e-6
                    && r.origin.x >= 1.0 - 1e-6
                    && r.origin.z <= 1e-6
                    && (r.origin.x - 1.0) - r.origin.z <= 2.0 + 1e-5
            );
            cos += r.dir.y as f64;
            centre += r.origin;
        }
        let n = (64 * 64) as f64;
        assert!((cos / n - 2.0 / 3.0).abs() < 1e-3, "{}", cos / n);
        let centre = centre / n as f32;
        assert!((centre - (a + b + c) / 3.0).length() < 2e-3, "{centre}");
    }

    /// A spot map's power is the spot's emitted power ∫ I falloff dΩ, computed here by
    /// integrating the falloff over the cone angle in double precision (2π ∫ falloff(cos θ)
    /// sin θ dθ): a midpoint rule on the map converges to it.
    #[test]
    fn spot_maps_carry_the_spots_power() {
        for (inner_deg, outer_deg) in [(10.0f64, 30.0f64), (0.0, 45.0), (40.0, 41.0), (60.0, 80.0)]
        {
            let (ci, co) = (inner_deg.to_radians().cos(), outer_deg.to_radians().cos());
            let steps = 200_000;
            let mut exact = 0.0f64;
            for s in 0..steps {
                let theta = (s as f64 + 0.5) / steps as f64 * outer_deg.to_radians();
                let t = ((theta.cos() - co) / (ci - co).max(1e-3)).clamp(0.0, 1.0);
                exact += t * t * theta.sin();
            }
            exact *= 2.0 * std::f64::consts::PI * outer_deg.to_radians() / steps as f64;
            let m = sized_one(
                spot(Vec3::ZERO, Vec3::new(0.0, -1.0, 0.0), Vec3::ONE, ci as f32, co as f32),
                512,
            );
            let mut total = 0.0f64;
            for t in 0..512 * 512 {
                if let Some(r) = texel_ray(&m, t) {
                    assert!((r.dir.length() - 1.0).abs() < 1e-5);
                    assert!(
                        r.dir.dot(Vec3::NEG_Y) >= co as f32 - 1e-6,
                        "a ray outside the outer cone"
                    );
                    total += r.power.x as f64;
                }
            }
            println!(
                "spot {inner_deg}-{outer_deg} deg: map power {total:.6}, ∫ I falloff dΩ {exact:.6}"
            );
            assert!((total / exact - 1.0).abs() < 2e-3, "{total} vs {exact}");
        }
    }

    /// A spot's map is the square around its outer cone, so that `--rsm-size` buys texels in
    /// the cone: the middle of each edge lies on the outer cone, and the cone's disc fills π/4 of
    /// the texels. A wider map would still carry the spot's power (the test above) with fewer
    /// VPLs than asked for. Every ray starts at the spot.
    #[test]
    fn a_spots_map_is_the_square_around_its_cone() {
        let (position, dir) = (Vec3::new(1.0, 2.0, -3.0), Vec3::new(0.0, -0.6, 0.8));
        for outer_deg in [5.0f32, 30.0, 45.0, 80.0] {
            let co = outer_deg.to_radians().cos();
            let light = spot(position, dir, Vec3::ONE, 1.0, co);
            for e in [light.e1, light.e2] {
                let edge = (dir + Vec3::from(e)).normalize();
                assert!(
                    (edge.dot(dir) - co).abs() < 1e-5,
                    "{outer_deg} deg: an edge's middle at cos {} for {co}",
                    edge.dot(dir)
                );
            }
            let m = sized_one(light, 256);
            let rays: Vec<TexelRay> = (0..256 * 256).filter_map(|t| texel_ray(&m, t)).collect();
            assert!(
                rays.iter().all(|r| r.origin == position),
                "{outer_deg} deg: a ray that does not start at the spot"
            );
            let inside = rays.len();
            let share = inside as f32 / (256.0 * 256.0);
            assert!(
                (share / (PI / 4.0) - 1.0).abs() < 0.01,
                "{outer_deg} deg: {share} of the texels in the cone, not π/4"
            );
        }
    }

    /// The warm start keeps each map's previous clusters in order, at most that map's share k,
    /// and drops those of maps that no longer exist: a map never starts with more clusters than
    /// it was given.
    #[test]
    fn warm_slots_keep_at_most_each_maps_share_in_order() {
        let centre = |map: u32, x: f32| RsmCentre { texel_x: x, map, ..Default::default() };
        let previous = [
            centre(0, 0.0),
            centre(1, 1.0),
            centre(0, 2.0),
            centre(0, 3.0),
            centre(2, 4.0),
            centre(1, 5.0),
            centre(0, 6.0),
        ];
        let slots = warm_slots(&previous, &[3, 5]);
        let xs = |m: usize| slots[m].iter().map(|c| c.texel_x).collect::<Vec<_>>();
        assert_eq!(slots.len(), 2);
        assert_eq!(xs(0), [0.0, 2.0, 3.0]);
        assert_eq!(xs(1), [1.0, 5.0]);
        assert!(warm_slots(&previous, &[0, 0]).iter().all(Vec::is_empty));
    }

    #[test]
    fn r2_points_are_uniform_and_the_same_bits_as_their_definition() {
        assert_eq!(r2_point(0), (0.5, 0.5));
        let g = 1.324_717_957_244_746f64;
        let mut mean = (0.0f64, 0.0f64);
        for k in 0..4096u32 {
            let (x, y) = r2_point(k);
            let fx = (0.5 + k as f64 / g).fract();
            let fy = (0.5 + k as f64 / (g * g)).fract();
            assert!(
                (x as f64 - fx).abs() < 1e-6 && (y as f64 - fy).abs() < 1e-6,
                "k {k}: {x} {y} vs {fx} {fy}"
            );
            mean = (mean.0 + x as f64, mean.1 + y as f64);
        }
        assert!((mean.0 / 4096.0 - 0.5).abs() < 1e-3 && (mean.1 / 4096.0 - 0.5).abs() < 1e-3);
    }
}
