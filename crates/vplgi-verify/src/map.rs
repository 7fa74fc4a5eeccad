//! Where a stage's items disagree, as a picture the size of the frame: each pixel coloured by the
//! worst kind of disagreement among the items that belong to it (its camera samples, its
//! compensation points, or the VPLs that project onto it). A pattern (a seam, a silhouette, an
//! emitter) is what a kernel author needs to see, and one number cannot show it.

use crate::shading_points::{Nudge, PointPair};
use glam::Vec3;
use serde::Serialize;
use vplgi_types::{Camera, ShadingPoint};

/// How one item compares, from agreement to the plainest disagreement; a pixel shows the worst
/// of its items.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
pub enum ItemKind {
    Agree,
    /// Another triangle at the same point (an edge two triangles share), or a rounding tie the
    /// stage's comparison sets aside.
    Tie,
    /// The same surface, but a value (position, emission, weight, radiance) beyond its bound.
    Beyond,
    /// Another surface, or a light path that went elsewhere.
    Other,
    /// A hit on one backend and a miss on the other.
    Miss,
}

impl ItemKind {
    pub const ALL: [ItemKind; 5] =
        [ItemKind::Agree, ItemKind::Tie, ItemKind::Beyond, ItemKind::Other, ItemKind::Miss];

    /// Its colour in the map (sRGB).
    pub fn colour(self) -> [u8; 3] {
        match self {
            ItemKind::Agree => [32, 32, 32],
            ItemKind::Tie => [70, 130, 255],
            ItemKind::Beyond => [230, 60, 230],
            ItemKind::Other => [255, 150, 0],
            ItemKind::Miss => [255, 30, 30],
        }
    }

    /// What it means, for the legend.
    pub fn meaning(self) -> &'static str {
        match self {
            ItemKind::Agree => "agree",
            ItemKind::Tie => {
                "a tie set aside (another triangle at the same point, or a rounding tie)"
            }
            ItemKind::Beyond => "the same surface, a value beyond its bound",
            ItemKind::Other => "another surface or path",
            ItemKind::Miss => "a miss on one backend only",
        }
    }
}

/// Items in the scene that disagree, each where it lies and how it compares: what
/// [`DisagreementMap::projected`] maps.
pub type Placed = Vec<(Vec3, ItemKind)>;

/// One stage's map of one case.
#[derive(Clone, Debug)]
pub struct DisagreementMap {
    pub case: String,
    pub width: u32,
    pub height: u32,
    /// Row-major, one per pixel.
    pub kinds: Vec<ItemKind>,
}

impl DisagreementMap {
    /// A map of `width` x `height` pixels that all agree.
    pub fn new(case: impl Into<String>, width: u32, height: u32) -> DisagreementMap {
        let kinds = vec![ItemKind::Agree; (width as usize) * (height as usize)];
        DisagreementMap { case: case.into(), width, height, kinds }
    }

    /// Records an item of `kind` at `pixel` (ignored outside the map).
    pub fn mark(&mut self, pixel: usize, kind: ItemKind) {
        if let Some(k) = self.kinds.get_mut(pixel) {
            *k = (*k).max(kind);
        }
    }

    /// Pixels of each kind, in [`ItemKind::ALL`]'s order.
    pub fn counts(&self) -> [usize; 5] {
        let mut n = [0; 5];
        for k in &self.kinds {
            n[*k as usize] += 1;
        }
        n
    }

    /// Whether some pixel holds a disagreement beyond a tie: a map worth drawing. (Edge ties
    /// are in most passing runs and are counted in the stage's table.)
    pub fn shows_disagreement(&self) -> bool {
        self.kinds.iter().any(|k| *k > ItemKind::Tie)
    }

    /// The map as packed RGB8.
    pub fn rgb8(&self) -> Vec<u8> {
        self.kinds.iter().flat_map(|k| k.colour()).collect()
    }

    /// Marks each pair of items of image-space points (`cpu[i]` against `gpu[i]`, their pixel
    /// the CPU's `pixel` field) by its kind: [`PointJudge::kind`].
    pub fn mark_points(&mut self, cpu: &[ShadingPoint], gpu: &[ShadingPoint], judge: &PointJudge) {
        for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
            self.mark(c.pixel as usize, judge.kind(i, c, g));
        }
    }

    /// A map of items in the scene (VPLs, points), each marked where `camera`'s `width` x
    /// `height` image sees it.
    pub fn projected(
        case: impl Into<String>,
        camera: &Camera,
        (width, height): (u32, u32),
        items: &[(Vec3, ItemKind)],
    ) -> DisagreementMap {
        let mut map = DisagreementMap::new(case, width, height);
        for &(p, kind) in items {
            map.mark_at(camera, p, kind);
        }
        map
    }

    /// Marks the pixel `camera` sees `p` in (nothing when `p` is behind it or outside the frame).
    pub fn mark_at(&mut self, camera: &Camera, p: Vec3, kind: ItemKind) {
        if let Some(pixel) = project(camera, p, self.width, self.height) {
            self.mark(pixel, kind);
        }
    }
}

/// How two backends' shading points (or compensation points) of the same sample are judged, as
/// `vplgi verify`'s shading-points rows judge them.
pub struct PointJudge<'a> {
    /// The scene's extent, the unit of positions.
    pub extent: f32,
    /// Where the rays come from: a position difference is judged times the cosine of incidence
    /// (`hit_differences` says why).
    pub eye: Vec3,
    /// The position bound, over the extent.
    pub position_bound: f64,
    /// Where the points are camera samples: a specular chain that parts within rounding is a tie.
    pub nudge: Option<Nudge<'a>>,
}

impl PointJudge<'_> {
    /// Of sample `i`: a miss on one side only; another triangle (a tie within 1e-5 of the
    /// extent, or a specular chain the CPU follows to the GPU's end when nudged); the same
    /// triangle with other emission, or positions apart beyond the bound where no mirror or
    /// glass came between (beyond); or agreement.
    pub fn kind(&self, i: usize, c: &ShadingPoint, g: &ShadingPoint) -> ItemKind {
        let pair = PointPair::of(c, g, self.extent, self.eye);
        let nudged = || {
            !pair.same
                && c.specular.max(g.specular) > 0
                && self.nudge.as_ref().is_some_and(|n| n.reaches(i, g))
        };
        if c.is_miss() != g.is_miss() {
            return if nudged() { ItemKind::Tie } else { ItemKind::Miss };
        }
        if !pair.same {
            return if pair.tie || nudged() { ItemKind::Tie } else { ItemKind::Other };
        }
        let direct = c.specular == 0 && g.specular == 0 && !c.is_miss();
        let emission_tie = || {
            !direct
                && self.nudge.as_ref().is_some_and(|n| n.camera.spp == 1 && n.sees_emission(i, g))
        };
        if !pair.emission_agrees && emission_tie() {
            ItemKind::Tie
        } else if !pair.emission_agrees
            || (direct && (pair.apart * pair.cos) as f64 > self.position_bound)
        {
            ItemKind::Beyond
        } else {
            ItemKind::Agree
        }
    }
}

/// The pixel of a `width` x `height` image of `camera` that sees `p`: the inverse of
/// [`Camera::ray_direction`].
pub fn project(camera: &Camera, p: Vec3, width: u32, height: u32) -> Option<usize> {
    let d = p - camera.position;
    let z = d.dot(camera.forward);
    if z <= 0.0 {
        return None;
    }
    let right = camera.forward.cross(camera.up).normalize();
    let tan_half = (0.5 * camera.yfov).tan();
    let aspect = width as f32 / height as f32;
    let sx = (d.dot(right) / z / (tan_half * aspect) + 1.0) * 0.5 * width as f32;
    let sy = (1.0 - d.dot(camera.up) / z / tan_half) * 0.5 * height as f32;
    let inside = (0.0..width as f32).contains(&sx) && (0.0..height as f32).contains(&sy);
    inside.then(|| sy as usize * width as usize + sx as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point on the ray through a pixel's centre projects back into that pixel.
    #[test]
    fn projection_inverts_the_camera_rays() {
        let camera = Camera::default();
        let (w, h) = (40, 32);
        for (x, y) in [(0u32, 0u32), (39, 31), (17, 5), (3, 30)] {
            let dir = camera.ray_direction(x as f32 + 0.5, y as f32 + 0.5, w, h);
            let p = camera.position + dir * 3.7;
            assert_eq!(project(&camera, p, w, h), Some((y * w + x) as usize), "pixel ({x}, {y})");
        }
        assert_eq!(project(&camera, camera.position - camera.forward, w, h), None);
    }

    /// A pixel shows its worst item, and agreement shows nothing.
    #[test]
    fn a_pixel_shows_its_worst_item() {
        let mut m = DisagreementMap::new("case", 2, 1);
        m.mark(1, ItemKind::Tie);
        assert!(!m.shows_disagreement());
        m.mark(0, ItemKind::Miss);
        assert!(m.shows_disagreement());
        m.mark(0, ItemKind::Tie);
        m.mark(1, ItemKind::Tie);
        m.mark(7, ItemKind::Miss);
        assert_eq!(m.kinds, vec![ItemKind::Miss, ItemKind::Tie]);
        assert_eq!(m.counts(), [0, 1, 0, 0, 1]);
        assert_eq!(&m.rgb8()[..3], &ItemKind::Miss.colour());
    }
}
