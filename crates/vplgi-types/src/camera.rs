//! The pinhole camera a frame is seen from, and camera paths: keyframed translation and
//! rotation of the camera node (glTF animation channels), sampled into one camera per frame.

use glam::{Mat4, Quat, Vec3};

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { position: Vec3::new(0.0, 0.0, 5.0), forward: -Vec3::Z, up: Vec3::Y, yfov: 0.7 }
    }
}

impl Camera {
    /// The primary ray direction through film position (`sx`, `sy`) in pixels, where (0, 0) is
    /// the top-left corner of the image.
    pub fn ray_direction(&self, sx: f32, sy: f32, width: u32, height: u32) -> Vec3 {
        let aspect = width as f32 / height as f32;
        let tan_half = (0.5 * self.yfov).tan();
        let right = self.forward.cross(self.up).normalize();
        let px = (2.0 * sx / width as f32 - 1.0) * tan_half * aspect;
        let py = (1.0 - 2.0 * sy / height as f32) * tan_half;
        (self.forward + right * px + self.up * py).normalize()
    }

    /// A camera that frames the box `[min, max]`, looking along -Z from in front of it.
    pub fn framing(min: Vec3, max: Vec3) -> Camera {
        let center = 0.5 * (min + max);
        let radius = (0.5 * (max - min).length()).max(1e-3);
        let yfov = 45f32.to_radians();
        let distance = radius / (0.5 * yfov).sin();
        Camera { position: center + Vec3::Z * distance, forward: -Vec3::Z, up: Vec3::Y, yfov }
    }

    /// The camera of a glTF camera node with world transform `world`: glTF cameras look down
    /// their local -z with +y up. `None` when the transform collapses the view direction or the
    /// field of view is not in (0, pi).
    pub fn from_world(world: &Mat4, yfov: f32) -> Option<Camera> {
        let forward = world.transform_vector3(-Vec3::Z).try_normalize()?;
        let up = world.transform_vector3(Vec3::Y);
        let up = (up - forward * up.dot(forward)).try_normalize()?;
        (yfov > 0.0 && yfov < std::f32::consts::PI).then(|| Camera {
            position: world.transform_point3(Vec3::ZERO),
            forward,
            up,
            yfov,
        })
    }

    /// The node rotation that makes a glTF camera look along `forward` with `up` (the inverse of
    /// [`Camera::from_world`]'s reading).
    pub fn rotation(&self) -> Quat {
        let z = -self.forward.normalize();
        let x = self.up.cross(z).normalize();
        let y = z.cross(x);
        Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
    }
}

/// One animated property: values at increasing key times, held before the first key and after
/// the last (glTF's rule), between keys linear (slerp for rotations) or stepped.
#[derive(Clone, Debug, PartialEq)]
pub struct Track<T> {
    times: Vec<f32>,
    values: Vec<T>,
    step: bool,
}

/// How a [`Track`] is read between keys.
pub trait Interpolate: Copy {
    fn between(a: Self, b: Self, s: f32) -> Self;
}

impl Interpolate for Vec3 {
    fn between(a: Self, b: Self, s: f32) -> Self {
        a.lerp(b, s)
    }
}

impl Interpolate for Quat {
    fn between(a: Self, b: Self, s: f32) -> Self {
        a.slerp(b, s)
    }
}

impl<T: Interpolate> Track<T> {
    /// A track of one value that never changes (no keys: it takes no part in a path's span).
    pub fn constant(value: T) -> Track<T> {
        Track { times: Vec::new(), values: vec![value], step: true }
    }

    /// A track from keys, refused when the counts differ (`times.len()` keys and
    /// `values.len()` values), there are none, or the times are not finite and increasing.
    pub fn new(times: Vec<f32>, values: Vec<T>, step: bool) -> Result<Track<T>, String> {
        if times.len() != values.len() {
            return Err(format!("{} key times but {} values", times.len(), values.len()));
        }
        if times.is_empty() {
            return Err("no keyframes".into());
        }
        if let Some(i) = times.iter().position(|t| !t.is_finite()) {
            return Err(format!("key time {i} is {}", times[i]));
        }
        if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!(
                "key times are not increasing: key {} at {} s follows {} s",
                i + 1,
                times[i + 1],
                times[i]
            ));
        }
        Ok(Track { times, values, step })
    }

    pub fn times(&self) -> &[f32] {
        &self.times
    }

    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// Whether values hold until the next key (glTF `STEP`) instead of interpolating.
    pub fn is_step(&self) -> bool {
        self.step
    }

    /// The first and last key times, if keyed.
    pub fn span(&self) -> Option<(f32, f32)> {
        Some((*self.times.first()?, *self.times.last()?))
    }

    /// The value at time `t`.
    pub fn at(&self, t: f32) -> T {
        let after = self.times.partition_point(|&k| k <= t);
        if after == 0 || self.times.len() < 2 {
            return self.values[0];
        }
        if after == self.times.len() {
            return self.values[after - 1];
        }
        let (t0, t1) = (self.times[after - 1], self.times[after]);
        if self.step {
            return self.values[after - 1];
        }
        T::between(self.values[after - 1], self.values[after], (t - t0) / (t1 - t0))
    }
}

/// A camera node's animation: world = `parent` x T(t) x R(t) x S, seen through `yfov`.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// World transform of the camera node's parent.
    pub parent: Mat4,
    pub translation: Track<Vec3>,
    pub rotation: Track<Quat>,
    pub scale: Vec3,
    pub yfov: f32,
}

impl CameraPath {
    /// The first and last key times of the keyed tracks ((0, 0) if neither is).
    pub fn span(&self) -> (f32, f32) {
        match (self.translation.span(), self.rotation.span()) {
            (Some(a), Some(b)) => (a.0.min(b.0), a.1.max(b.1)),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => (0.0, 0.0),
        }
    }

    /// The camera at time `t`, or `None` where the transform is degenerate.
    pub fn at(&self, t: f32) -> Option<Camera> {
        let local = Mat4::from_scale_rotation_translation(
            self.scale,
            self.rotation.at(t).normalize(),
            self.translation.at(t),
        );
        Camera::from_world(&(self.parent * local), self.yfov)
    }

    /// `frames` cameras at evenly spaced times from the first key to the last (one frame: the
    /// first key), refused when there are none or one is degenerate.
    pub fn frames(&self, frames: u32) -> Result<Vec<Camera>, String> {
        if frames == 0 {
            return Err("a sequence needs at least one frame".into());
        }
        let (t0, t1) = self.span();
        (0..frames)
            .map(|i| {
                let t =
                    if frames == 1 { t0 } else { t0 + (t1 - t0) * i as f32 / (frames - 1) as f32 };
                self.at(t).ok_or_else(|| format!("the camera's transform is degenerate at {t} s"))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `framing` backs away along +Z until the box's bounding sphere just fills the vertical
    /// field of view (sin(yfov / 2) = radius / distance), checked against numbers worked by hand.
    #[test]
    fn framing_fits_the_bounding_sphere_in_the_view() {
        let c = Camera::framing(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 2.0, 4.0));
        // Centre (1, 1, 3); radius |(4, 2, 2)| / 2 = 2.44949; distance 2.44949 / sin(22.5°) = 6.40083.
        assert!((c.position - Vec3::new(1.0, 1.0, 9.40083)).length() < 1e-4, "{c:?}");
        assert_eq!((c.forward, c.up), (-Vec3::Z, Vec3::Y));
        assert!((c.yfov - std::f32::consts::FRAC_PI_4).abs() < 1e-7, "{c:?}");
        // A box with no extent is still seen, from the distance of a sphere of radius 1e-3.
        let p = Camera::framing(Vec3::ONE, Vec3::ONE);
        assert!(
            (p.position - Vec3::new(1.0, 1.0, 1.0 + 1e-3 / 0.382_683_43)).length() < 1e-6,
            "{p:?}"
        );
    }

    /// A sheared node transform gives a camera whose up is the node's +y made orthogonal to the
    /// view direction (Gram-Schmidt), and a field of view outside (0, pi) gives none.
    #[test]
    fn from_world_orthogonalises_up_and_refuses_bad_fields_of_view() {
        // Local +y maps to (0, 1, 1) while local -z still maps to -z: up must become +y.
        let shear = Mat4::from_cols(
            Vec3::X.extend(0.0),
            Vec3::new(0.0, 1.0, 1.0).extend(0.0),
            Vec3::Z.extend(0.0),
            glam::Vec4::W,
        );
        let c = Camera::from_world(&shear, 1.0).unwrap();
        assert_eq!((c.forward, c.up), (-Vec3::Z, Vec3::Y));
        for yfov in [0.0, -1.0, std::f32::consts::PI, 4.0, f32::NAN] {
            assert_eq!(Camera::from_world(&Mat4::IDENTITY, yfov), None, "yfov {yfov}");
        }
        assert!(Camera::from_world(&Mat4::IDENTITY, 3.1).is_some());
    }

    /// The node rotation written for a camera reads back as the same camera.
    #[test]
    fn rotation_round_trips_through_from_world() {
        let c = Camera {
            position: Vec3::new(1.0, 2.0, 3.0),
            forward: Vec3::new(-0.3, -0.2, -1.0).normalize(),
            up: Vec3::Y,
            yfov: 0.9,
        };
        let c = Camera { up: (c.up - c.forward * c.up.dot(c.forward)).normalize(), ..c };
        let back =
            Camera::from_world(&Mat4::from_rotation_translation(c.rotation(), c.position), c.yfov)
                .unwrap();
        assert!(
            (back.forward - c.forward).length() < 1e-6 && (back.up - c.up).length() < 1e-6,
            "{back:?} vs {c:?}"
        );
        assert_eq!(back.position, c.position);
    }

    /// Between keys a track interpolates linearly (translations) or by slerp (rotations): the
    /// halfway rotation of a quarter turn is an eighth turn, not the normalised chord's
    /// value at other fractions.
    #[test]
    fn tracks_interpolate_hold_and_step() {
        let t =
            Track::new(vec![1.0, 3.0], vec![Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0)], false).unwrap();
        assert_eq!(t.at(2.5), Vec3::new(3.0, 0.0, 0.0));
        assert_eq!(t.at(0.0), Vec3::ZERO, "held before the first key");
        assert_eq!(t.at(9.0), Vec3::new(4.0, 0.0, 0.0), "held after the last key");
        let s = Track::new(vec![1.0, 3.0], vec![Vec3::ZERO, Vec3::X], true).unwrap();
        assert_eq!(s.at(2.9), Vec3::ZERO);
        let quarter = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let r = Track::new(vec![0.0, 1.0], vec![Quat::IDENTITY, quarter], false).unwrap();
        let at = r.at(0.25);
        let (axis, angle) = at.to_axis_angle();
        assert!(
            (angle - std::f32::consts::FRAC_PI_8).abs() < 1e-5 && (axis - Vec3::Y).length() < 1e-5,
            "{axis} {angle}"
        );
    }

    #[test]
    fn bad_keyframes_are_refused_by_name() {
        assert_eq!(
            Track::new(vec![0.0, 1.0], vec![Vec3::ZERO], false).unwrap_err(),
            "2 key times but 1 values"
        );
        assert!(Track::<Vec3>::new(vec![], vec![], false).unwrap_err().contains("no keyframes"));
        assert!(Track::new(vec![0.0, 0.0], vec![Vec3::ZERO; 2], false)
            .unwrap_err()
            .contains("not increasing"));
        assert!(Track::new(vec![0.0, f32::NAN], vec![Vec3::ZERO; 2], false)
            .unwrap_err()
            .contains("NaN"));
    }

    /// Frames sample the span evenly, ends included; zero frames are refused.
    #[test]
    fn frames_span_the_animation() {
        let path = CameraPath {
            parent: Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)),
            translation: Track::new(
                vec![2.0, 4.0],
                vec![Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0)],
                false,
            )
            .unwrap(),
            rotation: Track::constant(Quat::IDENTITY),
            scale: Vec3::ONE,
            yfov: 0.8,
        };
        let cams = path.frames(3).unwrap();
        let z: Vec<f32> = cams.iter().map(|c| c.position.z).collect();
        assert_eq!(z, vec![0.0, -1.0, -2.0]);
        assert!(cams.iter().all(|c| c.position.y == 1.0 && c.forward == -Vec3::Z && c.yfov == 0.8));
        assert_eq!(path.frames(1).unwrap()[0].position.z, 0.0);
        assert!(path.frames(0).unwrap_err().contains("at least one frame"));
    }
}
