//! Shadow segments judged in f64: whether rounding alone can decide if a segment is blocked.
//!
//! Embree, obvhs and the GPU each decide in f32 whether a triangle blocks the segment's span
//! t in (`SEGMENT_TNEAR`, `SEGMENT_TFAR`). Where a triangle comes within a few ulps of that span
//! without crossing it well inside (a blocker 6e-6 from an offset endpoint at the fold between
//! two triangles, a segment through a shared edge, a touch at the span's end), each of them is
//! right within its rounding, and their answers may differ. Such a pair is a tie: a disagreement
//! on it says nothing about a kernel. Everything else has one answer that every correct
//! backend must give.

use glam::DVec3;
use vplgi_types::params::{SEGMENT_TFAR, SEGMENT_TNEAR};

/// A scene's triangles in f64 and the distance below which rounding can move a surface.
pub struct TieOracle {
    tris: Vec<[DVec3; 3]>,
    tol: f64,
    /// A sphere holding every triangle: where a ray to infinity has left the scene.
    centre: DVec3,
    radius: f64,
}

/// How rounding can decide a segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Some triangle crosses the span with more than the tolerance to spare on every side.
    Blocked,
    /// No triangle comes within the tolerance of the span.
    Visible,
    /// Neither: a triangle is within the tolerance, none crosses with room to spare.
    Tie,
}

impl TieOracle {
    /// `tol` is 64 ulps of the scene's largest coordinate, the rounding scale the CPU's own ray
    /// offsets allow for (`Scene::ray_epsilon`): positions, offsets and hit parameters are all
    /// computed from coordinates of that size, and a few dozen roundings stay far below it.
    pub fn new(scene: &vplgi_scene::Scene) -> TieOracle {
        let (min, max) = scene.bounds();
        let far = min.abs().max(max.abs()).max_element() as f64;
        let tris =
            (0..scene.triangle_count()).map(|t| scene.triangle(t).map(|v| v.as_dvec3())).collect();
        let (min, max) = (min.as_dvec3(), max.as_dvec3());
        TieOracle {
            tris,
            tol: 64.0 * f32::EPSILON as f64 * far.max(1e-6),
            centre: (min + max) / 2.0,
            radius: (max - min).length() / 2.0,
        }
    }

    pub fn tolerance(&self) -> f64 {
        self.tol
    }

    /// The segment from `p` to `q` (the ends already pushed off their surfaces), over its span.
    pub fn verdict(&self, p: DVec3, q: DVec3) -> Verdict {
        self.span_verdict(p, q - p, SEGMENT_TNEAR as f64, SEGMENT_TFAR as f64)
    }

    /// The ray `o + t d` over t in (`tmin`, `tmax`), as a tracer is asked it (a
    /// `vplgi_cpu::ShadowSpan`). An infinite `tmax` (a directional light's ray) ends where the
    /// ray is more than the tolerance outside every triangle's bounding sphere.
    pub fn span_verdict(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> Verdict {
        let end = if tmax.is_finite() {
            tmax
        } else {
            ((o - self.centre).length() + self.radius + 2.0 * self.tol) / d.length()
        };
        let (a, b) = (o + d * tmin, o + d * end);
        let mut near = false;
        for tri in &self.tris {
            if crosses_with_room(a, b, tri, self.tol) {
                return Verdict::Blocked;
            }
            near |= is_near(a, b, tri, self.tol);
        }
        if near {
            Verdict::Tie
        } else {
            Verdict::Visible
        }
    }

    /// Whether rounding can change where the ray `o` + t `d` (t in (`tmin`, `tmax`)) first
    /// hits, or whether it hits: a triangle within the tolerance of the ray before its first
    /// hit with room to spare (or before `tmax` if it has none) that is not such a hit itself,
    /// as a hit at t ≈ `tmin`, a graze of an edge, or a near miss are.
    pub fn ray_is_tie(&self, o: DVec3, d: DVec3, tmin: f64, tmax: f64) -> bool {
        let (a, far) = (o + d * tmin, o + d * tmax);
        let robust: Vec<Option<f64>> =
            self.tris.iter().map(|tri| crossing_with_room(a, far, tri, self.tol)).collect();
        let first = robust.iter().flatten().fold(1.0f64, |m, &s| m.min(s));
        let b = a + (far - a) * first;
        self.tris.iter().zip(&robust).any(|(tri, r)| r.is_none() && is_near(a, b, tri, self.tol))
    }
}

/// Whether rounding can make a tracer report that segment `a`-`b` meets the triangle: it comes
/// within `tol` of it, or crosses its plane within [`room`] outside its edges. The second is the
/// mirror of the room a crossing needs inside: a segment 3.5e-5 rad from a triangle's plane,
/// crossing it 4e-4 outside an edge (tol 7.6e-6), was blocked by obvhs' Möller–Trumbore test
/// from one end and visible to Embree and from the other end (found at 10,000 cases).
fn is_near(a: DVec3, b: DVec3, tri: &[DVec3; 3], tol: f64) -> bool {
    segment_triangle_distance(a, b, tri) <= tol
        || plane_crossing(a, b, tri).is_some_and(|c| c.inside > -room(tol, c.sin))
}

/// Where a segment crosses a triangle's plane, its ends on opposite sides of it.
struct Crossing {
    /// The fraction of the way from the first end.
    s: f64,
    /// The ends' signed distances from the plane.
    heights: (f64, f64),
    /// The smallest signed distance from the crossing to an edge's line, positive inside.
    inside: f64,
    /// The sine of the segment's angle to the plane.
    sin: f64,
}

fn plane_crossing(a: DVec3, b: DVec3, [v0, v1, v2]: &[DVec3; 3]) -> Option<Crossing> {
    let n = (*v1 - *v0).cross(*v2 - *v0);
    let len = n.length();
    if len == 0.0 {
        return None;
    }
    let n = n / len;
    let (da, db) = (n.dot(a - *v0), n.dot(b - *v0));
    if da == 0.0 || db == 0.0 || (da > 0.0) == (db > 0.0) {
        return None;
    }
    let s = da / (da - db);
    let x = a + (b - a) * s;
    let inside = [(*v0, *v1), (*v1, *v2), (*v2, *v0)].iter().fold(f64::INFINITY, |m, &(e0, e1)| {
        let e = e1 - e0;
        m.min(n.cross(e).dot(x - e0) / e.length())
    });
    Some(Crossing { s, heights: (da, db), inside, sin: (da - db).abs() / (b - a).length() })
}

/// How far along a triangle's plane rounding can move a segment's crossing: moving the segment
/// by `tol` across the plane slides the crossing by `tol` times the cotangent of their angle. A
/// segment 1.5e-4 rad from a triangle's plane, 1.03e-5 inside an edge (tol 9.5e-6), was blocked
/// on Embree and the GPU and missed from both ends by obvhs' Möller–Trumbore test (found at
/// 10,000 cases).
fn room(tol: f64, sin: f64) -> f64 {
    tol * (1.0 + (1.0 - sin * sin).max(0.0).sqrt() / sin)
}

/// Whether segment `a`-`b` crosses the triangle's plane at a point inside it with room to spare
/// from each edge (`tol`, more for a segment near the plane), with both ends more than `tol`
/// from the plane.
fn crosses_with_room(a: DVec3, b: DVec3, tri: &[DVec3; 3], tol: f64) -> bool {
    crossing_with_room(a, b, tri, tol).is_some()
}

/// [`crosses_with_room`]'s crossing as a fraction of the way from `a` to `b`: the ends more than
/// `tol` from the plane, the crossing more than [`room`] inside every edge.
fn crossing_with_room(a: DVec3, b: DVec3, tri: &[DVec3; 3], tol: f64) -> Option<f64> {
    let c = plane_crossing(a, b, tri)?;
    (c.heights.0.abs() > tol && c.heights.1.abs() > tol && c.inside > room(tol, c.sin))
        .then_some(c.s)
}

/// Distance between segment `a`-`b` and a triangle (0 if they meet).
pub fn segment_triangle_distance(a: DVec3, b: DVec3, tri: &[DVec3; 3]) -> f64 {
    let [v0, v1, v2] = *tri;
    if segment_meets_triangle(a, b, tri) {
        return 0.0;
    }
    // Apart, the closest pair has an end of the segment or a point on an edge of the triangle.
    let ends = point_triangle_distance(a, tri).min(point_triangle_distance(b, tri));
    [(v0, v1), (v1, v2), (v2, v0)]
        .iter()
        .fold(ends, |m, &(e0, e1)| m.min(segment_segment_distance(a, b, e0, e1)))
}

fn segment_meets_triangle(a: DVec3, b: DVec3, [v0, v1, v2]: &[DVec3; 3]) -> bool {
    let n = (*v1 - *v0).cross(*v2 - *v0);
    let (da, db) = (n.dot(a - *v0), n.dot(b - *v0));
    if n == DVec3::ZERO || (da > 0.0 && db > 0.0) || (da < 0.0 && db < 0.0) || da == db {
        return false;
    }
    let x = a + (b - a) * (da / (da - db));
    [(*v0, *v1), (*v1, *v2), (*v2, *v0)]
        .iter()
        .all(|&(e0, e1)| n.dot((e1 - e0).cross(x - e0)) >= 0.0)
}

/// Distance from `p` to the triangle: to its interior if `p` projects inside, else to the nearest
/// edge.
pub(crate) fn point_triangle_distance(p: DVec3, [v0, v1, v2]: &[DVec3; 3]) -> f64 {
    let n = (*v1 - *v0).cross(*v2 - *v0);
    let edges = [(*v0, *v1), (*v1, *v2), (*v2, *v0)];
    if n != DVec3::ZERO && edges.iter().all(|&(e0, e1)| n.dot((e1 - e0).cross(p - e0)) >= 0.0) {
        return (n.normalize().dot(p - *v0)).abs();
    }
    edges.iter().map(|&(e0, e1)| point_segment_distance(p, e0, e1)).fold(f64::INFINITY, f64::min)
}

fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - p).length()
}

/// Distance between segments `p1`-`q1` and `p2`-`q2`: the closest points of their lines,
/// clamped to the segments, one parameter re-solved after the other is clamped.
fn segment_segment_distance(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    if a == 0.0 {
        return point_segment_distance(p1, p2, q2);
    }
    if e == 0.0 {
        return point_segment_distance(p2, p1, q1);
    }
    let (b, c) = (d1.dot(d2), d1.dot(r));
    let denom = a * e - b * b;
    let mut s = if denom > 0.0 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (p1 + d1 * s - (p2 + d2 * t)).length()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    /// The unit right triangle in the plane z = 0.
    const TRI: [DVec3; 3] = [DVec3::ZERO, DVec3::X, DVec3::Y];

    #[test]
    fn distances_match_hand_computed_values() {
        // Straight through the interior.
        assert_eq!(segment_triangle_distance(v(0.2, 0.2, 1.0), v(0.2, 0.2, -1.0), &TRI), 0.0);
        // Stops 0.5 above the interior.
        assert!(
            (segment_triangle_distance(v(0.2, 0.2, 2.0), v(0.2, 0.2, 0.5), &TRI) - 0.5).abs()
                < 1e-15
        );
        // Passes the hypotenuse x + y = 1 at (0.75, 0.75): sqrt(2) / 4 from it.
        let d = segment_triangle_distance(v(0.75, 0.75, 1.0), v(0.75, 0.75, -1.0), &TRI);
        assert!((d - 2f64.sqrt() / 4.0).abs() < 1e-15, "{d}");
        // Skew to an edge: the line x = -0.3, z = 0.4 runs along y, 0.5 from the edge on the y axis.
        let d = segment_triangle_distance(v(-0.3, -1.0, 0.4), v(-0.3, 2.0, 0.4), &TRI);
        assert!((d - 0.5).abs() < 1e-15, "{d}");
    }

    #[test]
    fn a_crossing_needs_room_on_every_side() {
        let tol = 1e-6;
        assert!(crosses_with_room(v(0.2, 0.2, 1.0), v(0.2, 0.2, -1.0), &TRI, tol));
        // Through the edge on the x axis: no room.
        assert!(!crosses_with_room(v(0.5, 0.0, 1.0), v(0.5, 0.0, -1.0), &TRI, tol));
        // Just inside the edge, by less than tol and by more.
        assert!(!crosses_with_room(v(0.5, 5e-7, 1.0), v(0.5, 5e-7, -1.0), &TRI, tol));
        assert!(crosses_with_room(v(0.5, 2e-6, 1.0), v(0.5, 2e-6, -1.0), &TRI, tol));
        // An end 5e-7 past the plane: a touch rounding may miss.
        assert!(!crosses_with_room(v(0.2, 0.2, 1.0), v(0.2, 0.2, -5e-7), &TRI, tol));
        // 45 degrees from the plane, 1.5e-6 inside the edge: rounding across the plane moves
        // the crossing by up to tol along it, so 2 tol is needed.
        assert!(!crosses_with_room(
            v(0.5, 1.5e-6 - 1.0, 1.0),
            v(0.5, 1.5e-6 + 1.0, -1.0),
            &TRI,
            tol
        ));
        assert!(crosses_with_room(
            v(0.5, 2.5e-6 - 1.0, 1.0),
            v(0.5, 2.5e-6 + 1.0, -1.0),
            &TRI,
            tol
        ));
        // 1e-3 rad from the plane, 1e-4 inside the edge: no room (it needs about 1e-3).
        assert!(!crosses_with_room(v(0.5, 1e-4 - 1.0, 1e-3), v(0.5, 1e-4 + 1.0, -1e-3), &TRI, tol));
        // Either winding.
        assert!(crosses_with_room(
            v(0.2, 0.2, 1.0),
            v(0.2, 0.2, -1.0),
            &[DVec3::ZERO, DVec3::Y, DVec3::X],
            tol
        ));
    }

    #[test]
    fn a_near_miss_is_near_by_the_room_rounding_gives_it() {
        let tol = 1e-6;
        // Crossing the plane 4e-4 outside the edge on the x axis: steeply, far from the triangle;
        // along the edge 3.5e-5 rad from the plane (never nearer the triangle than 4e-4), within
        // the room rounding gives it (tol / 3.5e-5 = 0.029), so a tie.
        assert!(!is_near(v(0.5, -4e-4, 1.0), v(0.5, -4e-4, -1.0), &TRI, tol));
        assert!(is_near(v(-0.5, -4e-4, 3.5e-5), v(1.5, -4e-4, -3.5e-5), &TRI, tol));
        assert!(
            segment_triangle_distance(v(-0.5, -4e-4, 3.5e-5), v(1.5, -4e-4, -3.5e-5), &TRI) > 3e-4
        );
        // Within tol of the edge without crossing the plane, and clear of it.
        assert!(is_near(v(0.5, -5e-7, 1.0), v(0.5, -5e-7, 1e-7), &TRI, tol));
        assert!(!is_near(v(0.5, -1e-3, 1.0), v(0.5, -1e-3, 1e-7), &TRI, tol));
    }

    /// The unit square in z = 0, two triangles sharing the diagonal x = y, no lights.
    pub(crate) fn square() -> vplgi_scene::Scene {
        let mut s = vplgi_scene::cornell::cornell_box();
        s.positions =
            vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::new(1.0, 1.0, 0.0), glam::Vec3::Y];
        s.normals = vec![glam::Vec3::Z; 4];
        s.uvs = vec![glam::Vec2::ZERO; 4];
        s.indices = vec![[0, 1, 2], [0, 2, 3]];
        s.material_ids = vec![0, 0];
        s.lights.clear();
        s
    }

    #[test]
    fn verdicts_on_a_unit_square() {
        let o = TieOracle::new(&square());
        assert!((o.tolerance() - 64.0 * f32::EPSILON as f64).abs() < 1e-18);
        assert_eq!(o.verdict(v(0.3, 0.6, 1.0), v(0.3, 0.6, -1.0)), Verdict::Blocked);
        // Through the shared diagonal: blocked in exact arithmetic, but no triangle has room.
        assert_eq!(o.verdict(v(0.5, 0.5, 1.0), v(0.5, 0.5, -1.0)), Verdict::Tie);
        assert_eq!(o.verdict(v(2.0, 0.5, 1.0), v(2.0, 0.5, -1.0)), Verdict::Visible);
        // Ending 1e-7 short of the square: the span stops SEGMENT_TNEAR (1e-5) earlier, 1.01e-5
        // above it, beyond the tolerance (7.6e-6).
        let p = v(0.3, 0.6, 1.0);
        assert_eq!(o.verdict(p, v(0.3, 0.6, 1e-7)), Verdict::Visible);
        // The span's end 1e-7 past the plane: a crossing that rounding may miss.
        let end = v(0.3, 0.6, -1e-7);
        assert_eq!(o.verdict(p, p + (end - p) / SEGMENT_TFAR as f64), Verdict::Tie);
    }

    #[test]
    fn spans_to_infinity_are_judged_until_they_leave_the_scene() {
        let o = TieOracle::new(&square());
        let inf = f64::INFINITY;
        assert_eq!(o.span_verdict(v(0.3, 0.6, 1.0), v(0.0, 0.0, -1.0), 0.0, inf), Verdict::Blocked);
        assert_eq!(o.span_verdict(v(0.3, 0.6, 1.0), v(0.0, 0.0, 1.0), 0.0, inf), Verdict::Visible);
        assert_eq!(o.span_verdict(v(0.5, 0.5, 1.0), v(0.0, 0.0, -1.0), 0.0, inf), Verdict::Tie);
        // From far away (100 above, a short direction): still reaches the square.
        assert_eq!(
            o.span_verdict(v(0.3, 0.6, 100.0), v(0.0, 0.0, -1e-3), 0.0, inf),
            Verdict::Blocked
        );
        // A finite span is the segment it says: stopping 0.5 above the square.
        assert_eq!(o.span_verdict(v(0.3, 0.6, 1.0), v(0.0, 0.0, -1.0), 0.0, 0.5), Verdict::Visible);
    }

    #[test]
    fn rays_that_rounding_can_decide() {
        let o = TieOracle::new(&square());
        let down = v(0.0, 0.0, -1.0);
        // A hit well inside, and a clean miss: decided.
        assert!(!o.ray_is_tie(v(0.3, 0.6, 1.0), down, 1e-3, 10.0));
        assert!(!o.ray_is_tie(v(1.1, 0.5, 1.0), down, 1e-3, 10.0));
        // Through the shared diagonal, 1e-6 past the square's edge, and a hit 1e-7 past tmin.
        assert!(o.ray_is_tie(v(0.5, 0.5, 1.0), down, 1e-3, 10.0));
        assert!(o.ray_is_tie(v(1.0 + 1e-6, 0.5, 1.0), down, 1e-3, 10.0));
        assert!(o.ray_is_tie(v(0.3, 0.6, 1e-3 + 1e-7), down, 1e-3, 10.0));
        // A graze beyond a clean first hit does not matter: a triangle 1 below the square with a
        // corner on the ray.
        let mut s = square();
        let n = s.positions.len() as u32;
        s.positions.extend([
            glam::Vec3::new(0.3, 0.6, -1.0),
            glam::Vec3::new(1.3, 0.6, -1.0),
            glam::Vec3::new(1.3, 1.6, -1.0),
        ]);
        s.normals.extend([glam::Vec3::Z; 3]);
        s.uvs.extend([glam::Vec2::ZERO; 3]);
        s.indices.push([n, n + 1, n + 2]);
        s.material_ids.push(0);
        let o2 = TieOracle::new(&s);
        assert!(!o2.ray_is_tie(v(0.3, 0.6, 1.0), down, 1e-3, 10.0));
        assert!(o2.ray_is_tie(v(0.3, 0.6, -0.5), down, 1e-3, 10.0));
    }
}
