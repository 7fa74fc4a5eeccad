//! Choosing area lights for direct light by what they can contribute at a shading point.
//!
//! Emitters are cut into at most [`MAX_GROUPS`] runs of consecutive triangles (a mesh's triangles
//! are usually consecutive, so a run is compact). Each group carries a bounding sphere, a cone
//! around its normals and its power. At a shading point p with normal n, a group's importance is
//! its power times an upper bound of each cosine of the geometry term, over the distance squared
//! to its centre (the importance of a light-tree node in Conty Estevez and Kulla, "Importance
//! Sampling of Many Lights with Adaptive Tree Splitting", 2018, with one level):
//!
//!   I = Φ · cos(max(θ_p − θ_s, 0)) · cos(max(θ_l − θ_n − θ_s, 0)) / max(d², r²)
//!
//! where θ_s is the half-angle the sphere subtends from p, θ_p the angle between n and the
//! direction to the centre, θ_l the angle between the cone's axis and the direction from the
//! centre to p, and θ_n the cone's half-angle; a cosine bound whose angle reaches π/2 makes the
//! importance zero. The bounds are upper bounds: a group that can light p from any of its points
//! has I > 0, so choosing groups with probability I / ΣI and then an emitter by power keeps the
//! estimator unbiased. Only cosines, products and square roots appear (no inverse trigonometry),
//! so the WGSL twin (`group_importance` in `shaders/common/lights.wgsl`) follows it operation by
//! operation.

use crate::device::LightGroup;
use glam::Vec3;

/// The most groups direct light chooses among (the GPU keeps no per-group array: it recomputes).
pub const MAX_GROUPS: usize = 32;

/// `cone[3]` of a group whose normals spread too far for a useful cone: no light-side bound.
pub const ANY_ORIENTATION: f32 = -2.0;

/// cos(max(θ − β, 0)) from cos θ and (cos β, sin β), for θ and β in [0, π]: 1 when θ ≤ β, else
/// cos θ cos β + sin θ sin β (negative once θ − β passes π/2).
#[inline]
pub fn cos_bound(cos_t: f32, cos_b: f32, sin_b: f32) -> f32 {
    if cos_t >= cos_b {
        1.0
    } else {
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        cos_t * cos_b + sin_t * sin_b
    }
}

/// The importance of `g` at point `p` with unit normal `n` (module docs); 0 when no point of the
/// group can light p.
#[inline]
pub fn group_importance(g: &LightGroup, p: Vec3, n: Vec3) -> f32 {
    let c = Vec3::new(g.sphere[0], g.sphere[1], g.sphere[2]);
    let r = g.sphere[3];
    let d = c - p;
    let d2 = d.dot(d);
    let r2 = r * r;
    if d2 <= r2 {
        // Inside the bounding sphere light can come from any direction.
        return g.power[0] / r2.max(f32::MIN_POSITIVE);
    }
    let dist = d2.sqrt();
    let sin_s = r / dist;
    let cos_s = (1.0 - sin_s * sin_s).max(0.0).sqrt();
    let bound_p = cos_bound(n.dot(d) / dist, cos_s, sin_s);
    if bound_p <= 0.0 {
        return 0.0;
    }
    let mut bound_l = 1.0;
    let cos_n = g.cone[3];
    if cos_n > ANY_ORIENTATION {
        let axis = Vec3::new(g.cone[0], g.cone[1], g.cone[2]);
        let sin_n = (1.0 - cos_n * cos_n).max(0.0).sqrt();
        // The widest angle a point of the group sees p at: θ_n + θ_s (at most π, as θ_n ≤ π/2).
        let cos_b = cos_n * cos_s - sin_n * sin_s;
        let sin_b = sin_n * cos_s + cos_n * sin_s;
        bound_l = cos_bound(-axis.dot(d) / dist, cos_b, sin_b);
        if bound_l <= 0.0 {
            return 0.0;
        }
    }
    g.power[0] * bound_p * bound_l / d2
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(centre: Vec3, r: f32, axis: Vec3, cos_n: f32) -> LightGroup {
        LightGroup {
            sphere: [centre.x, centre.y, centre.z, r],
            cone: [axis.x, axis.y, axis.z, cos_n],
            power: [2.0, 1.0, 0.0, 0.0],
            range: [0, 1, 0, 0],
        }
    }

    /// Hand-computed cases: a small light straight above a floor point, facing down, is power /
    /// d² (both bounds 1); turned away, or below the floor, it is 0.
    #[test]
    fn importance_of_hand_checked_cases() {
        let g = group(Vec3::new(0.0, 2.0, 0.0), 0.1, Vec3::NEG_Y, 1.0);
        let i = group_importance(&g, Vec3::ZERO, Vec3::Y);
        assert!((i - 2.0 / 4.0).abs() < 1e-6, "{i}");
        let up = group(Vec3::new(0.0, 2.0, 0.0), 0.1, Vec3::Y, 1.0);
        assert_eq!(group_importance(&up, Vec3::ZERO, Vec3::Y), 0.0);
        assert_eq!(group_importance(&g, Vec3::ZERO, Vec3::NEG_Y), 0.0);
        // Off to the side at 60° from the floor normal, sphere subtending asin(0.1/2): the receiver
        // bound is cos(60° - asin(0.05)).
        let side = group(Vec3::new(3f32.sqrt(), 1.0, 0.0), 0.1, Vec3::NEG_Y, 1.0);
        let i = group_importance(&side, Vec3::ZERO, Vec3::Y);
        let theta_s = (0.1f32 / 2.0).asin();
        // The light's axis against the direction from its centre to p: also 60°.
        let light = Vec3::NEG_Y.dot(Vec3::new(-(3f32.sqrt()), -1.0, 0.0) / 2.0).acos();
        let want = 2.0 * (60f32.to_radians() - theta_s).cos() * (light - theta_s).cos() / 4.0;
        assert!((i - want).abs() < 1e-5 * want, "{i} vs {want}");
        // Inside the sphere: power / r².
        assert!(
            (group_importance(&g, Vec3::new(0.0, 1.95, 0.0), Vec3::Y) - 2.0 / 0.01).abs() < 1e-3
        );
    }

    /// The bounds are upper bounds: whenever some point of a random triangle lights a random
    /// receiver (both cosines positive), the importance of a group made of it is positive.
    #[test]
    fn importance_is_positive_wherever_a_triangle_point_can_light() {
        let mut rng = crate::rng::Rng::new(11, crate::rng::Stream::Direct, 0);
        let mut f = || rng.next_f32();
        let mut checked = 0;
        for _ in 0..3000 {
            let v: Vec<Vec3> = (0..3).map(|_| Vec3::new(f(), f(), f()) * 2.0 - 1.0).collect();
            let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            if !normal.is_finite() {
                continue;
            }
            let centre = (v[0] + v[1] + v[2]) / 3.0;
            let r = v.iter().map(|x| (*x - centre).length()).fold(0.0, f32::max);
            let g = group(centre, r, normal, 1.0);
            let p = Vec3::new(f(), f(), f()) * 6.0 - 3.0;
            let n = crate::sampling::uniform_sphere(f(), f());
            let lit = (0..64).any(|_| {
                let (b1, b2) = crate::sampling::uniform_triangle(f(), f());
                let x = v[0] + (v[1] - v[0]) * b1 + (v[2] - v[0]) * b2;
                let d = x - p;
                n.dot(d) > 1e-4 * d.length() && -normal.dot(d) > 1e-4 * d.length()
            });
            if lit {
                checked += 1;
                assert!(
                    group_importance(&g, p, n) > 0.0,
                    "triangle {v:?} lights {p} (normal {n}) but has importance 0"
                );
            }
        }
        assert!(checked > 300, "only {checked} lit cases");
    }
}
