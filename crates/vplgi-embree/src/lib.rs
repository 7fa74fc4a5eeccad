//! A small safe wrapper over Embree 4 for the CPU reference.
//!
//! What it offers is exactly what vplgi needs: one triangle mesh per scene held in shared buffers
//! (no copy inside Embree), `occluded` (`rtcOccluded1`) and `intersect` (`rtcIntersect1`) on a
//! committed scene that is `Send + Sync`, so rayon workers query it concurrently.
//!
//! **The 4.4 hit struct.** embree4-sys 0.0.12 generates its bindings from Embree 4.2 headers, but
//! the runtime installed by `ci/install-deps.sh` is Embree 4.4, whose `RTCHit` gained an
//! `instPrimID` field. Passing the 4.2 `RTCRayHit` to `rtcIntersect1` lets Embree write 4 bytes
//! past the Rust value. [`RayHit`] is laid out like the 4.4 struct, and a test checks that the
//! bytes after it stay untouched while `instPrimID` is written.

use embree4_sys as sys;
use glam::Vec3;
use std::ffi::CString;
use std::ptr;

/// Errors reported by Embree.
#[derive(Debug, thiserror::Error)]
pub enum EmbreeError {
    #[error("Embree could not create a device (is the Embree 4 runtime installed? run ci/install-deps.sh): {0:?}")]
    Device(sys::RTCError),
    #[error("Embree failed to {what}: {code:?}")]
    Call { what: &'static str, code: sys::RTCError },
}

/// An Embree device. Cheap to share: scenes keep their own reference to it.
pub struct Device {
    raw: sys::RTCDevice,
}

// SAFETY: Embree devices are internally synchronised; the API may be called from any thread.
unsafe impl Send for Device {}
unsafe impl Sync for Device {}

impl Device {
    /// Creates a device. `threads` bounds Embree's own (TBB) build threads; `None` lets Embree
    /// decide. Queries always run on the caller's thread.
    pub fn new(threads: Option<usize>) -> Result<Device, EmbreeError> {
        let config = match threads {
            Some(n) => format!("threads={n},verbose=0"),
            None => "verbose=0".to_string(),
        };
        // The config string has no interior NUL by construction.
        let config = CString::new(config)
            .map_err(|_| EmbreeError::Device(sys::RTCError::INVALID_ARGUMENT))?;
        // SAFETY: a valid NUL-terminated string; a null device is checked below.
        let raw = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError(NULL) returns the error of the last failed device creation.
            return Err(EmbreeError::Device(error_from_u32(unsafe {
                raw_device_error(ptr::null_mut())
            })));
        }
        Ok(Device { raw })
    }

    fn check(&self, what: &'static str) -> Result<(), EmbreeError> {
        // SAFETY: self.raw is a live device; see `raw_device_error` for why the code is read as u32.
        match unsafe { raw_device_error(self.raw) } {
            0 => Ok(()),
            code => Err(EmbreeError::Call { what, code: error_from_u32(code) }),
        }
    }
}

// The 4.4 runtime can return error codes the 4.2 bindings' Rust enum lacks (7, "Level Zero
// raytracing support missing"); receiving one as that enum would be undefined behaviour. So the
// code is read as a plain integer and mapped.
extern "C" {
    #[link_name = "rtcGetDeviceError"]
    fn raw_device_error(device: sys::RTCDevice) -> u32;
}

fn error_from_u32(code: u32) -> sys::RTCError {
    match code {
        0 => sys::RTCError::NONE,
        2 => sys::RTCError::INVALID_ARGUMENT,
        3 => sys::RTCError::INVALID_OPERATION,
        4 => sys::RTCError::OUT_OF_MEMORY,
        5 => sys::RTCError::UNSUPPORTED_CPU,
        6 => sys::RTCError::CANCELLED,
        _ => sys::RTCError::UNKNOWN,
    }
}

impl Clone for Device {
    fn clone(&self) -> Self {
        // SAFETY: retaining a live device.
        unsafe { sys::rtcRetainDevice(self.raw) };
        Device { raw: self.raw }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: paired with rtcNewDevice / rtcRetainDevice.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}

/// The Embree 4.4 `RTCHit`: the 4.2 layout plus `instPrimID`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct Hit44 {
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub prim_id: u32,
    pub geom_id: u32,
    pub inst_id: [u32; 1],
    pub inst_prim_id: [u32; 1],
}

/// The Embree 4.4 `RTCRayHit`, safe to hand to `rtcIntersect1` of the 4.4 runtime.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
pub struct RayHit {
    pub ray: sys::RTCRay,
    pub hit: Hit44,
}

const INVALID_ID: u32 = u32::MAX;

fn make_ray(origin: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: origin.x,
        org_y: origin.y,
        org_z: origin.z,
        tnear,
        dir_x: dir.x,
        dir_y: dir.y,
        dir_z: dir.z,
        time: 0.0,
        tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl RayHit {
    pub fn new(origin: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> RayHit {
        RayHit {
            ray: make_ray(origin, dir, tnear, tfar),
            hit: Hit44 {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: INVALID_ID,
                geom_id: INVALID_ID,
                inst_id: [INVALID_ID],
                inst_prim_id: [INVALID_ID],
            },
        }
    }
}

/// The closest intersection along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (in units of the direction's length).
    pub t: f32,
    /// Index of the triangle in the index array given to [`Scene::new`].
    pub triangle: u32,
    /// Barycentric coordinates of the hit: weight of vertex 1 and of vertex 2.
    pub u: f32,
    pub v: f32,
}

/// A committed triangle scene. Immutable, `Send + Sync`.
pub struct Scene {
    raw: sys::RTCScene,
    _device: Device,
    // Embree reads these through the shared-buffer pointers for the scene's whole life. Their heap
    // storage never moves because the vectors are never touched again.
    _vertices: Vec<f32>,
    _indices: Vec<u32>,
    triangles: usize,
}

// SAFETY: Embree documents committed scenes as safe to query concurrently from many threads;
// the scene is never modified after `Scene::new` returns.
unsafe impl Send for Scene {}
unsafe impl Sync for Scene {}

/// Vectors as [x, y, z] arrays of their components.
fn soa<const N: usize>(v: &[Vec3; N]) -> [[f32; N]; 3] {
    [v.map(|v| v.x), v.map(|v| v.y), v.map(|v| v.z)]
}

/// The body of `occludedN`: an N-wide SoA packet (origins and directions as [x, y, z] arrays of
/// N) and valid mask, aligned to ALIGN bytes as rtcOccludedN requires, in the layout of Embree
/// 4's RTCRayN (unchanged in 4.4); bit k of the result is set when segment k (of the first
/// `count`) is blocked.
macro_rules! packet_query {
    ($scene:expr, $org:expr, $dir:expr, $count:expr, $tnear:expr, $tfar:expr, $n:literal, $align:literal, $ray:ident, $query:ident) => {{
        #[repr(C, align($align))]
        struct Packet(sys::$ray);
        #[repr(C, align($align))]
        struct Valid([std::os::raw::c_int; $n]);
        let count = $count.min($n);
        let mut p = Packet(sys::$ray {
            org_x: $org[0],
            org_y: $org[1],
            org_z: $org[2],
            tnear: [$tnear; $n],
            dir_x: $dir[0],
            dir_y: $dir[1],
            dir_z: $dir[2],
            time: [0.0; $n],
            tfar: [$tfar; $n],
            mask: [u32::MAX; $n],
            id: [0; $n],
            flags: [0; $n],
        });
        let valid = Valid(std::array::from_fn(|k| if k < count { -1 } else { 0 }));
        // SAFETY: the packet and the valid mask have the alignment and layout rtcOccludedN
        // requires (above); null arguments mean default query arguments. Embree writes only the
        // packet's tfar, to -inf where a segment is blocked.
        unsafe { sys::$query(valid.0.as_ptr(), $scene.raw, &mut p.0, ptr::null_mut()) };
        (0..count).fold(0u16, |bits, k| bits | (((p.0.tfar[k] < 0.0) as u16) << k))
    }};
}

impl Scene {
    /// Builds a scene from vertex positions and triangles (indices into `positions`).
    /// Index validity is the caller's responsibility only up to this check: out-of-range indices
    /// are rejected.
    pub fn new(
        device: &Device,
        positions: &[Vec3],
        indices: &[[u32; 3]],
    ) -> Result<Scene, EmbreeError> {
        if indices.iter().flatten().any(|&i| i as usize >= positions.len()) {
            return Err(EmbreeError::Call {
                what: "build the scene (index out of range)",
                code: sys::RTCError::INVALID_ARGUMENT,
            });
        }
        // Embree may read 16 bytes at the last vertex: one float of padding keeps that in bounds.
        let mut vertices = Vec::with_capacity(positions.len() * 3 + 1);
        for p in positions {
            vertices.extend_from_slice(&[p.x, p.y, p.z]);
        }
        vertices.push(0.0);
        let idx: Vec<u32> = indices.iter().flatten().copied().collect();

        // SAFETY: every handle is checked or comes from a live device; the buffers outlive the
        // scene (they are moved into it below and never modified).
        unsafe {
            let raw = sys::rtcNewScene(device.raw);
            device.check("create a scene")?;
            sys::rtcSetSceneFlags(raw, sys::RTCSceneFlags::ROBUST);
            sys::rtcSetSceneBuildQuality(raw, sys::RTCBuildQuality::HIGH);
            if !indices.is_empty() {
                let geom = sys::rtcNewGeometry(device.raw, sys::RTCGeometryType::TRIANGLE);
                sys::rtcSetSharedGeometryBuffer(
                    geom,
                    sys::RTCBufferType::VERTEX,
                    0,
                    sys::RTCFormat::FLOAT3,
                    vertices.as_ptr().cast(),
                    0,
                    12,
                    positions.len(),
                );
                sys::rtcSetSharedGeometryBuffer(
                    geom,
                    sys::RTCBufferType::INDEX,
                    0,
                    sys::RTCFormat::UINT3,
                    idx.as_ptr().cast(),
                    0,
                    12,
                    indices.len(),
                );
                sys::rtcCommitGeometry(geom);
                sys::rtcAttachGeometry(raw, geom);
                sys::rtcReleaseGeometry(geom);
            }
            sys::rtcCommitScene(raw);
            let scene = Scene {
                raw,
                _device: device.clone(),
                _vertices: vertices,
                _indices: idx,
                triangles: indices.len(),
            };
            device.check("commit the scene")?;
            Ok(scene)
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// True when something blocks the segment `origin + t * dir` for t in (`tnear`, `tfar`).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> bool {
        let mut ray = make_ray(origin, dir, tnear, tfar);
        // SAFETY: `ray` is a valid RTCRay (its layout did not change in 4.4); null arguments mean
        // default query arguments.
        unsafe { sys::rtcOccluded1(self.raw, &mut ray, ptr::null_mut()) };
        // Embree marks an occluded ray by setting tfar to -inf.
        ray.tfar < 0.0
    }

    /// `occluded` for up to 4 segments at once (`rtcOccluded4`): see [`Self::occluded8`].
    pub fn occluded4(
        &self,
        origins: &[Vec3; 4],
        dirs: &[Vec3; 4],
        count: usize,
        tnear: f32,
        tfar: f32,
    ) -> u16 {
        packet_query!(
            self,
            soa(origins),
            soa(dirs),
            count,
            tnear,
            tfar,
            4,
            16,
            RTCRay4,
            rtcOccluded4
        )
    }

    /// `occluded` for up to 8 segments at once (`rtcOccluded8`, Embree's packet query): segment
    /// `k` of the first `count` is `origins[k] + t * dirs[k]` for t in (`tnear`, `tfar`); bit k
    /// of the result is set when it is blocked. For `make perf-report`'s question whether
    /// packets of coherent shadow rays beat the one-ray loop, and which width does.
    pub fn occluded8(
        &self,
        origins: &[Vec3; 8],
        dirs: &[Vec3; 8],
        count: usize,
        tnear: f32,
        tfar: f32,
    ) -> u16 {
        packet_query!(
            self,
            soa(origins),
            soa(dirs),
            count,
            tnear,
            tfar,
            8,
            32,
            RTCRay8,
            rtcOccluded8
        )
    }

    /// [`Self::occluded8`] for segments that all start at `origin`, their directions given as
    /// [x, y, z] arrays (the layout of Embree's packet, so nothing is rearranged): the shadow
    /// rays of one shading point.
    pub fn occluded8_from(
        &self,
        origin: Vec3,
        dirs: &[[f32; 8]; 3],
        count: usize,
        tnear: f32,
        tfar: f32,
    ) -> u16 {
        let org = [[origin.x; 8], [origin.y; 8], [origin.z; 8]];
        packet_query!(self, org, *dirs, count, tnear, tfar, 8, 32, RTCRay8, rtcOccluded8)
    }

    /// `occluded` for up to 16 segments at once (`rtcOccluded16`): see [`Self::occluded8`].
    pub fn occluded16(
        &self,
        origins: &[Vec3; 16],
        dirs: &[Vec3; 16],
        count: usize,
        tnear: f32,
        tfar: f32,
    ) -> u16 {
        packet_query!(
            self,
            soa(origins),
            soa(dirs),
            count,
            tnear,
            tfar,
            16,
            64,
            RTCRay16,
            rtcOccluded16
        )
    }

    /// Closest hit along `origin + t * dir` for t in (`tnear`, `tfar`).
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<Hit> {
        let mut rh = RayHit::new(origin, dir, tnear, tfar);
        self.intersect_raw(&mut rh);
        (rh.hit.geom_id != INVALID_ID).then_some(Hit {
            t: rh.ray.tfar,
            triangle: rh.hit.prim_id,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    /// `rtcIntersect1` on a 4.4-layout ray-hit record.
    pub fn intersect_raw(&self, rh: &mut RayHit) {
        // SAFETY: `RayHit` has the size and layout of the 4.4 runtime's RTCRayHit, so Embree's
        // writes stay inside it (tested by `intersect_writes_nothing_past_the_hit_struct`).
        unsafe { sys::rtcIntersect1(self.raw, (rh as *mut RayHit).cast(), ptr::null_mut()) };
    }
}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: paired with rtcNewScene; the buffers are dropped after this.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

#[cfg(test)]
mod tests;
