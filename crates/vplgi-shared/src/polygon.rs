//! VPL clusters as convex polygons: the area lights of Prutkin et al. 2012 in their other form
//! (section 5 and Fig. 3 compare disks with the point-to-polygon form factor).
//!
//! Why a second shape: a disk sized by its members' spread ([`crate::disk`]) is round where the
//! cluster is not. A cluster against a wall is cut off by the wall, and its disk, centred at the
//! representative, reaches through it: receivers on the wall see that part of the disk from
//! behind, below their horizon, and its light is lost (on the Cornell box, exact disks keep
//! 0.98–0.99 of the light where the unclustered VPLs keep 0.996).
//!
//! The polygon is the members' extent in [`SIDES`] directions of the representative's plane, 45°
//! apart ([`support`]): the smallest convex polygon with sides in those directions that holds
//! every member's projection ([`Outline::new`]). It ends where the members end, so a cluster cut
//! by a wall gives a polygon cut by it too. Its flux Φ leaves the polygon evenly, and it is lit
//! through its exact form factor ([`geometry_term`]): Lambert's contour integral over the part
//! above the receiver's horizon, divided by the area so that it stands where a point light's
//! cos θ_p cos θ_c / d² does. A cluster whose members span no area (one VPL, or a line of them)
//! stays a clamped point, as a disk of radius 0 does.

use crate::disk::{member_weight, perpendicular};
use glam::{Vec2, Vec3};
use vplgi_types::LightOutline;

/// Directions of the outline, and its most vertices (the record's size).
pub const SIDES: usize = vplgi_types::pod::OUTLINE_SIDES;

/// Where [`Outline::new`] counts a vertex as on a diagonal side: within this share of the
/// outline's largest support value.
pub const CUT_TOLERANCE: f32 = 1e-5;

/// The in-plane unit directions of the outline around `normal`: u_a = cos(a π/4) t + sin(a π/4) b
/// in the frame t = [`perpendicular`]`(normal)`, b = normal × t (counterclockwise about it).
pub fn directions(normal: Vec3) -> [Vec3; SIDES] {
    let (t, b) = frame(normal);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    [t, (t + b) * h, b, (b - t) * h, -t, -(t + b) * h, -b, (t - b) * h]
}

/// The frame of the outline's plane: t, b with t × b = normal.
pub fn frame(normal: Vec3) -> (Vec3, Vec3) {
    let t = perpendicular(normal);
    (t, normal.cross(t))
}

/// Per direction u_a of [`directions`], the largest (x − centre) · u_a over the members (position,
/// flux) that carry light, and at least 0: the outline always holds the centre. Members without
/// flux emit nothing and do not widen it.
pub fn support(
    members: impl Iterator<Item = (Vec3, Vec3)>,
    centre: Vec3,
    normal: Vec3,
) -> [f32; SIDES] {
    let u = directions(normal);
    let mut s = [0.0f32; SIDES];
    for (x, flux) in members {
        if member_weight(flux) > 0.0 {
            let d = x - centre;
            for (s, u) in s.iter_mut().zip(&u) {
                *s = s.max(u.dot(d));
            }
        }
    }
    s
}

/// A convex polygon in the plane frame of [`frame`]: `count` vertices, counterclockwise.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outline {
    pub vertices: [Vec2; SIDES],
    pub count: usize,
}

impl Outline {
    /// The outline on the plane through `centre` facing `normal` as the light's record, each
    /// vertex carrying the area; no vertices at all for an outline without area (a cluster that
    /// stays a point).
    pub fn light_outline(&self, centre: Vec3, normal: Vec3) -> LightOutline {
        let mut record = LightOutline::default();
        let area = self.area();
        if area > 0.0 {
            for (slot, v) in record.vertices.iter_mut().zip(self.placed(centre, normal)) {
                *slot = [v.x, v.y, v.z, area];
            }
        }
        record
    }

    /// The polygon {q : q · u_a ≤ s_a for every a}, u_a the directions of [`directions`] in the
    /// plane frame: the rectangle of the four axis directions, its corners cut by the four
    /// diagonal ones. Each cut adds at most one vertex, so at most [`SIDES`].
    pub fn new(support: &[f32; SIDES]) -> Outline {
        let [s0, s1, s2, s3, s4, s5, s6, s7] = *support;
        let mut o = Outline { count: 4, ..Default::default() };
        o.vertices[..4].copy_from_slice(&[
            Vec2::new(s0, -s6),
            Vec2::new(s0, s2),
            Vec2::new(-s4, s2),
            Vec2::new(-s4, -s6),
        ]);
        let eps = CUT_TOLERANCE * support.iter().fold(0.0f32, |m, s| m.max(*s));
        let h = std::f32::consts::FRAC_1_SQRT_2;
        for (d, s) in [
            (Vec2::new(h, h), s1),
            (Vec2::new(-h, h), s3),
            (Vec2::new(-h, -h), s5),
            (Vec2::new(h, -h), s7),
        ] {
            o = o.clipped(d, s, eps);
        }
        o
    }

    /// The part with q · d ≤ s (Sutherland and Hodgman's clip against one line), where a vertex
    /// within `eps` of the line counts as on it. On members from a grid, a diagonal's support is
    /// taken at a corner member, so the line passes through the rectangle's corner up to
    /// rounding: without the tolerance, the corner would be cut off on one backend (two vertices
    /// a rounding error apart) and kept on the other. Each cut adds at most one vertex.
    fn clipped(&self, d: Vec2, s: f32, eps: f32) -> Outline {
        let mut out = Outline::default();
        let mut push = |v: Vec2| {
            if out.count < SIDES {
                out.vertices[out.count] = v;
                out.count += 1;
            }
        };
        for i in 0..self.count {
            let (a, b) = (self.vertices[i], self.vertices[(i + 1) % self.count]);
            let (da, db) = (d.dot(a) - s, d.dot(b) - s);
            let (a_in, b_in) = (da <= eps, db <= eps);
            if a_in {
                push(a);
            }
            // The crossing, unless the inside end is on the line (then it is that end).
            if a_in != b_in && da.min(db) < -eps {
                push(a + (b - a) * (da / (da - db)));
            }
        }
        out
    }

    /// The area (the shoelace formula; ≥ 0 for a counterclockwise outline).
    pub fn area(&self) -> f32 {
        let mut twice = 0.0f32;
        for i in 0..self.count {
            let (a, b) = (self.vertices[i], self.vertices[(i + 1) % self.count]);
            twice += a.perp_dot(b);
        }
        (0.5 * twice).max(0.0)
    }

    /// The vertices in space, on the plane through `centre` facing `normal`.
    pub fn placed(&self, centre: Vec3, normal: Vec3) -> impl Iterator<Item = Vec3> + '_ {
        let (t, b) = frame(normal);
        self.vertices[..self.count].iter().map(move |v| centre + t * v.x + b * v.y)
    }
}

/// The exact form factor from the point `p` with unit normal `n` to the Lambertian polygon with
/// `vertices` (counterclockwise about its unit `normal`, which it emits toward) and `area`,
/// divided by the area: (1 / A) ∫ cos θ_p cos θ_z / d² dA over the part above p's horizon, where
/// a point light has cos θ_p cos θ_c / d². 0 when p is behind the polygon's plane.
///
/// Lambert's contour form: ∫ cos θ_p cos θ_z / d² dA = −½ Σ_edges γ n · (r_a × r_b) / |r_a × r_b|
/// over the boundary of the part above the horizon, r = z − p and γ the angle between r_a and
/// r_b. That boundary is each edge's part above the horizon plus, where the horizon cuts the
/// polygon, the chord from where the boundary leaves the half-space to where it comes back. So
/// the edges are clipped one by one as they are read, with no list of clipped vertices (which
/// the GPU twin would keep in a dynamically indexed private array).
pub fn geometry_term(p: Vec3, n: Vec3, normal: Vec3, vertices: &[Vec3], area: f32) -> f32 {
    let Some(&first) = vertices.first() else {
        return 0.0;
    };
    if !(normal.dot(p - first) > 0.0 && area > 0.0) {
        return 0.0;
    }
    let mut sum = 0.0f32;
    let (mut exit, mut entry) = (None, None);
    for (i, &a) in vertices.iter().enumerate() {
        let (ra, rb) = (a - p, vertices[(i + 1) % vertices.len()] - p);
        let (ha, hb) = (n.dot(ra), n.dot(rb));
        if ha >= 0.0 && hb >= 0.0 {
            sum += edge(ra, rb, n);
        } else if ha >= 0.0 || hb >= 0.0 {
            let x = ra + (rb - ra) * (ha / (ha - hb));
            if ha >= 0.0 {
                sum += edge(ra, x, n);
                exit = Some(x);
            } else {
                sum += edge(x, rb, n);
                entry = Some(x);
            }
        }
    }
    if let (Some(x), Some(y)) = (exit, entry) {
        sum += edge(x, y, n);
    }
    (-0.5 * sum / area).max(0.0)
}

/// One edge's term of the contour sum: γ n · (a × b) / |a × b|, 0 for an edge through p's line of
/// sight (a × b = 0).
#[inline]
fn edge(a: Vec3, b: Vec3, n: Vec3) -> f32 {
    let c = a.cross(b);
    let len = c.length();
    if len > 0.0 {
        len.atan2(a.dot(b)) * n.dot(c) / len
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vplgi_types::{Rng, Stream};

    /// (1 / A) ∫ cos θ_p cos θ_z / d² dA over the polygon above p's horizon, by a midpoint rule
    /// on a `cells` × `cells` grid over the outline's bounding box, in f64: the definition,
    /// sharing nothing with the contour form but the outline.
    fn quadrature(p: Vec3, n: Vec3, centre: Vec3, normal: Vec3, o: &Outline, cells: usize) -> f64 {
        let (t, b) = frame(normal);
        let (lo, hi) = o.vertices[..o.count]
            .iter()
            .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        let inside = |q: Vec2| {
            (0..o.count).all(|i| {
                (o.vertices[(i + 1) % o.count] - o.vertices[i]).perp_dot(q - o.vertices[i]) >= 0.0
            })
        };
        let (w, h) = ((hi.x - lo.x) as f64 / cells as f64, (hi.y - lo.y) as f64 / cells as f64);
        let mut sum = 0.0;
        for i in 0..cells {
            for j in 0..cells {
                let q = Vec2::new(
                    lo.x + ((i as f64 + 0.5) * w) as f32,
                    lo.y + ((j as f64 + 0.5) * h) as f32,
                );
                if !inside(q) {
                    continue;
                }
                let z = centre + t * q.x + b * q.y;
                let d = (z - p).as_dvec3();
                let d2 = d.length_squared();
                let cos_p = n.as_dvec3().dot(d) / d2.sqrt();
                let cos_z = -normal.as_dvec3().dot(d) / d2.sqrt();
                if cos_p > 0.0 && cos_z > 0.0 {
                    sum += cos_p * cos_z / d2 * w * h;
                }
            }
        }
        sum / o.area() as f64
    }

    fn placed(o: &Outline, centre: Vec3, normal: Vec3) -> Vec<Vec3> {
        o.placed(centre, normal).collect()
    }

    #[test]
    fn directions_are_unit_45_degrees_apart_and_counterclockwise() {
        for normal in [Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let u = directions(normal);
            for a in 0..SIDES {
                let (x, y) = (u[a], u[(a + 1) % SIDES]);
                assert!((x.length() - 1.0).abs() < 1e-6 && x.dot(normal).abs() < 1e-6);
                assert!((x.dot(y) - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
                assert!(x.cross(y).dot(normal) > 0.0);
            }
        }
    }

    #[test]
    fn a_square_of_members_gives_that_square() {
        // Members on the square [-1, 2] x [-0.5, 1] of the plane: the diagonals cut nothing.
        let normal = Vec3::Z;
        let (t, b) = frame(normal);
        let members: Vec<(Vec3, Vec3)> = (0..=30)
            .flat_map(|i| {
                (0..=15).map(move |j| {
                    (t * (-1.0 + 0.1 * i as f32) + b * (-0.5 + 0.1 * j as f32), Vec3::ONE)
                })
            })
            .collect();
        let o = Outline::new(&support(members.into_iter(), Vec3::ZERO, normal));
        assert_eq!(o.count, 4);
        assert!((o.area() - 4.5).abs() < 1e-4, "{}", o.area());
        let want = [
            Vec2::new(2.0, -0.5),
            Vec2::new(2.0, 1.0),
            Vec2::new(-1.0, 1.0),
            Vec2::new(-1.0, -0.5),
        ];
        for (got, want) in o.vertices[..4].iter().zip(want) {
            assert!((*got - want).length() < 1e-5, "{got} vs {want}");
        }
    }

    #[test]
    fn a_diagonal_through_a_corner_cuts_nothing_whichever_way_it_rounds() {
        // A rectangle of grid members: the diagonal support is the corner's own, so the line
        // passes through the corner up to rounding. Nudged either way by a few ulps, the outline
        // is the same four corners (no second vertex a rounding error away).
        let corner = (0.6f32 + 0.4) * std::f32::consts::FRAC_1_SQRT_2;
        for nudge in [-3i32, -1, 0, 1, 3] {
            let s1 = f32::from_bits((corner.to_bits() as i32 + nudge) as u32);
            let o = Outline::new(&[0.6, s1, 0.4, 9.0, 0.6, 9.0, 0.4, 9.0]);
            assert_eq!(o.count, 4, "nudge {nudge}: {:?}", &o.vertices[..o.count]);
        }
        // A real cut still cuts.
        assert_eq!(Outline::new(&[0.6, 0.6, 0.4, 9.0, 0.6, 9.0, 0.4, 9.0]).count, 5);
    }

    #[test]
    fn members_on_a_disk_give_the_regular_octagon_around_it() {
        let normal = Vec3::new(0.2, 0.9, -0.1).normalize();
        let centre = Vec3::new(1.0, 2.0, 3.0);
        let (t, b) = frame(normal);
        let members = (0..720).map(|i| {
            let phi = i as f32 * std::f32::consts::TAU / 720.0;
            (centre + (t * phi.cos() + b * phi.sin()) * 0.5, Vec3::ONE)
        });
        let o = Outline::new(&support(members, centre, normal));
        assert_eq!(o.count, 8);
        // The regular octagon circumscribing a circle of radius r has area 8 r² tan(π/8).
        let want = 8.0 * 0.25 * (std::f32::consts::PI / 8.0).tan();
        assert!((o.area() / want - 1.0).abs() < 1e-3, "{} vs {want}", o.area());
    }

    #[test]
    fn a_cluster_against_a_wall_stops_at_the_wall() {
        // Members fill the half-disk x ≥ 0 (a wall at x = 0), its representative at x = 0.3: the
        // outline's side toward the wall is at x = 0, where a disk of the members' spread around
        // the representative would reach past it.
        let normal = Vec3::Z;
        let (t, b) = frame(normal);
        let mut members = Vec::new();
        for i in 0..40 {
            for j in -40..=40 {
                let q = Vec2::new(i as f32 * 0.025, j as f32 * 0.025);
                if q.length() <= 1.0 {
                    members.push((t * q.x + b * q.y, Vec3::ONE));
                }
            }
        }
        let centre = t * 0.3;
        let o = Outline::new(&support(members.iter().copied(), centre, normal));
        let least = o.vertices[..o.count].iter().map(|v| v.x).fold(f32::MAX, f32::min);
        assert!((least + 0.3).abs() < 1e-5, "the outline reaches x = {} of the wall's -0.3", least);
        let r2 = crate::disk::radius2(members.iter().copied(), normal);
        assert!(
            r2.sqrt() > 0.5,
            "the disk of the same members reaches {} past the wall",
            r2.sqrt() - 0.3
        );
    }

    #[test]
    fn members_without_flux_or_area_give_no_outline() {
        let normal = Vec3::Y;
        let dark = [(Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO), (Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO)];
        assert_eq!(Outline::new(&support(dark.into_iter(), Vec3::ZERO, normal)).area(), 0.0);
        let line = (0..10).map(|i| (Vec3::new(i as f32, 0.0, 0.0), Vec3::ONE));
        assert_eq!(Outline::new(&support(line, Vec3::ZERO, normal)).area(), 0.0);
    }

    /// The form factor from a point over the corner of an x × y rectangle, parallel to it at
    /// distance h: F = (1/2π) (X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))), X = x/h,
    /// Y = y/h, in f64.
    fn corner_form_factor(x: f64, y: f64, h: f64) -> f64 {
        let (x, y) = (x / h, y / h);
        (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
            + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
            / (2.0 * std::f64::consts::PI)
    }

    /// A point at height h on the axis of a parallel square of side 2a, centred at `centre` and
    /// facing `normal`: four times [`corner_form_factor`], times π / A.
    fn check_on_the_axis_of_a_square(centre: Vec3, normal: Vec3) {
        for (a, h) in [(0.5f32, 0.1f32), (0.5, 1.0), (1.0, 7.0), (2.0, 0.01)] {
            let o = Outline::new(&[a, 9.0, a, 9.0, a, 9.0, a, 9.0]);
            assert_eq!(o.count, 4);
            let area = o.area();
            let g = geometry_term(
                centre + normal * h,
                -normal,
                normal,
                &placed(&o, centre, normal),
                area,
            );
            let want =
                4.0 * corner_form_factor(a as f64, a as f64, h as f64) * std::f64::consts::PI
                    / area as f64;
            assert!(
                (g as f64 / want - 1.0).abs() < 1e-4,
                "normal {normal}, centre {centre}, a {a} h {h}: {g} vs {want}"
            );
        }
    }

    #[test]
    fn on_the_axis_of_a_square_the_term_matches_the_closed_form() {
        check_on_the_axis_of_a_square(Vec3::ZERO, Vec3::Z);
    }

    /// The same closed form for squares whose plane is no coordinate plane, away from the origin
    /// (tilted about one axis, about two, and one normal near x that takes `perpendicular`'s
    /// other branch): the outline's frame (`frame`) and its placed vertices then mix all three
    /// axes, so a frame that is not orthonormal, or turns clockwise about the normal (the contour
    /// sum changes sign and the term clamps to 0), or a vertex placed off the plane fails here,
    /// and not only where the plane is a coordinate plane.
    #[test]
    fn on_the_axis_of_a_tilted_square_the_term_matches_the_closed_form() {
        let centre = Vec3::new(0.25, -0.5, 0.125);
        for normal in [
            Vec3::new(0.0, 0.6, 0.8),
            Vec3::new(0.3, -0.8, 0.2).normalize(),
            Vec3::new(-0.48, 0.6, 0.64),
            Vec3::new(0.95, 0.3, -0.1).normalize(),
        ] {
            check_on_the_axis_of_a_square(centre, normal);
        }
    }

    #[test]
    fn the_term_matches_quadrature_anywhere_in_front_horizon_cuts_included() {
        // Random outlines from random members, receivers at random places and orientations in
        // front of the plane, some with the horizon through the polygon, against the midpoint
        // rule. A wrong sign, a dropped clip or a wrong area fails by far more than 1 %.
        let mut rng = Rng::new(13, Stream::Oracle, 2);
        let mut cut = 0;
        for case in 0..60 {
            let normal = vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
            let centre = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let (t, b) = frame(normal);
            let members: Vec<(Vec3, Vec3)> = (0..12)
                .map(|_| {
                    (
                        centre + t * (rng.next_f32() - 0.5) * 2.0 + b * (rng.next_f32() - 0.5),
                        Vec3::ONE,
                    )
                })
                .collect();
            let o = Outline::new(&support(members.into_iter(), centre, normal));
            let verts = placed(&o, centre, normal);
            let dir = vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
            let p = centre
                + normal * (0.05 + 1.5 * rng.next_f32())
                + (dir - normal * dir.dot(normal)) * 1.5 * rng.next_f32();
            let n = vplgi_types::sampling::uniform_sphere(rng.next_f32(), rng.next_f32());
            let g = geometry_term(p, n, normal, &verts, o.area()) as f64;
            let want = quadrature(p, n, centre, normal, &o, 1200);
            let below = verts.iter().filter(|v| n.dot(**v - p) < 0.0).count();
            cut += (below > 0 && below < verts.len()) as usize;
            assert!((g - want).abs() <= 0.01 * want.abs() + 1e-4, "case {case}: {g} vs {want}");
        }
        assert!(cut >= 10, "only {cut} cases had the horizon through the polygon");
    }

    #[test]
    fn far_away_the_polygon_is_a_point() {
        let normal = Vec3::Y;
        let o = Outline::new(&[0.1; SIDES]);
        let verts = placed(&o, Vec3::ZERO, normal);
        let p = Vec3::new(3.0, 40.0, -2.0);
        let n = -p.normalize();
        let d = -p;
        let point = n.dot(-d).abs() / d.length() * normal.dot(-d) / d.length() / d.length_squared();
        let g = geometry_term(p, n, normal, &verts, o.area());
        assert!((g / point - 1.0).abs() < 1e-3, "{g} vs {point}");
        // Behind the plane: nothing.
        assert_eq!(geometry_term(-p, -n, normal, &verts, o.area()), 0.0);
    }
}
