//! Embree 3 as a measuring stick for the traversal bench (`--features embree`): the scene's
//! primitives in one Embree scene, traced with Embree's single-ray and packet kernels.
//!
//! A hand-written binding of the few C functions used (Debian's `libembree-dev` 3.13: the
//! kernel Mitsuba 3 and Cycles use on CPUs). Triangles are one triangle mesh (geometry 0, one
//! Embree primitive per torrey triangle) and spheres one `RTC_GEOMETRY_TYPE_SPHERE_POINT`
//! geometry (1), so every hit maps back to torrey's primitive index.

use glam::Vec3A;
use std::ffi::{c_char, c_void};
use torrey_renderer::{PrimGeom, Ray, RenderScene};

type Handle = *mut c_void;

const GEOMETRY_TRIANGLE: u32 = 0;
const GEOMETRY_SPHERE_POINT: u32 = 50;
const BUFFER_INDEX: u32 = 0;
const BUFFER_VERTEX: u32 = 1;
const FORMAT_UINT3: u32 = 0x5003;
const FORMAT_FLOAT3: u32 = 0x9003;
const FORMAT_FLOAT4: u32 = 0x9004;
const INVALID_ID: u32 = u32::MAX;
/// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`: camera rays.
const COHERENT: u32 = 1;

/// Embree's build quality (`RTCBuildQuality`).
#[derive(Clone, Copy, Debug)]
#[allow(dead_code)] // each is selectable through TORREY_EMBREE_QUALITY
pub enum Quality {
    Low = 0,
    /// Embree's default.
    Medium = 1,
    High = 2,
}

#[repr(C)]
struct Context {
    flags: u32,
    filter: *const c_void,
    inst_id: [u32; 1],
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct Ray1 {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct Hit1 {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 1],
}

#[repr(C)]
struct RayHit1 {
    ray: Ray1,
    hit: Hit1,
}

/// `RTCRayHitN` for N = 8 and 16: structure-of-arrays rays and hits.
#[repr(C, align(64))]
struct RayHitN<const N: usize> {
    org: [[f32; N]; 3],
    tnear: [f32; N],
    dir: [[f32; N]; 3],
    time: [f32; N],
    tfar: [f32; N],
    mask: [u32; N],
    id: [u32; N],
    flags: [u32; N],
    ng: [[f32; N]; 3],
    u: [f32; N],
    v: [f32; N],
    prim_id: [u32; N],
    geom_id: [u32; N],
    inst_id: [u32; N],
}

/// The packet kernels' mask of active lanes (all), aligned as the packets.
#[repr(C, align(64))]
struct Valid<const N: usize>([i32; N]);

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> Handle;
    fn rtcReleaseDevice(device: Handle);
    fn rtcGetDeviceError(device: Handle) -> u32;
    fn rtcNewScene(device: Handle) -> Handle;
    fn rtcSetSceneBuildQuality(scene: Handle, quality: u32);
    fn rtcCommitScene(scene: Handle);
    fn rtcReleaseScene(scene: Handle);
    fn rtcNewGeometry(device: Handle, kind: u32) -> Handle;
    fn rtcSetNewGeometryBuffer(
        geometry: Handle,
        kind: u32,
        slot: u32,
        format: u32,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: Handle);
    fn rtcAttachGeometry(scene: Handle, geometry: Handle) -> u32;
    fn rtcReleaseGeometry(geometry: Handle);
    fn rtcIntersect1(scene: Handle, context: *mut Context, rayhit: *mut RayHit1);
    fn rtcOccluded1(scene: Handle, context: *mut Context, ray: *mut Ray1);
    fn rtcIntersect8(
        valid: *const Valid<8>,
        scene: Handle,
        context: *mut Context,
        rayhit: *mut RayHitN<8>,
    );
    fn rtcIntersect16(
        valid: *const Valid<16>,
        scene: Handle,
        context: *mut Context,
        rayhit: *mut RayHitN<16>,
    );
}

/// One Embree device and scene over a [`RenderScene`]'s primitives.
pub struct Embree {
    device: Handle,
    scene: Handle,
    /// torrey's primitive index of each Embree (geometry, primitive).
    prims: [Vec<u32>; 2],
}

impl Embree {
    /// Builds the scene with one build thread (`threads=1`: no worker threads stay around to
    /// disturb the single-threaded timings); `TORREY_EMBREE_CONFIG` adds to the device's
    /// configuration (e.g. `isa=avx2`, `verbose=2`).
    pub fn new(scene: &RenderScene, quality: Quality) -> Self {
        let mut triangles = Vec::new();
        let mut spheres = Vec::new();
        let mut prims = [Vec::new(), Vec::new()];
        for i in 0..scene.accel().primitive_count() as u32 {
            match scene.prim_geom(i) {
                PrimGeom::Triangle { p0, p1, p2 } => {
                    triangles.push([p0, p1, p2]);
                    prims[0].push(i);
                }
                PrimGeom::Sphere { center, radius } => {
                    spheres.push(center.extend(radius));
                    prims[1].push(i);
                }
                // The bench scenes have none; Embree's user geometry would be needed for them.
                PrimGeom::Disk { .. } | PrimGeom::Cylinder { .. } | PrimGeom::SdfVoxel { .. } => {
                    panic!("the Embree comparison handles triangles and spheres only")
                }
            }
        }
        // SAFETY: the buffers Embree allocates are written within their item counts and
        // strides; every handle is checked for errors after the build.
        unsafe {
            let mut config = "threads=1".to_string();
            if let Ok(extra) = std::env::var("TORREY_EMBREE_CONFIG") {
                config = format!("{config},{extra}");
            }
            let config = std::ffi::CString::new(config).expect("no NUL in TORREY_EMBREE_CONFIG");
            let device = rtcNewDevice(config.as_ptr());
            assert!(!device.is_null(), "Embree device");
            let handle = rtcNewScene(device);
            rtcSetSceneBuildQuality(handle, quality as u32);
            // Geometry IDs follow attachment order: triangles 0, spheres 1 (even when empty).
            let geom = rtcNewGeometry(device, GEOMETRY_TRIANGLE);
            let n = triangles.len();
            let vertices = rtcSetNewGeometryBuffer(geom, BUFFER_VERTEX, 0, FORMAT_FLOAT3, 16, 3 * n)
                as *mut [f32; 4];
            let indices = rtcSetNewGeometryBuffer(geom, BUFFER_INDEX, 0, FORMAT_UINT3, 12, n)
                as *mut [u32; 3];
            for (t, tri) in triangles.iter().enumerate() {
                for (k, p) in tri.iter().enumerate() {
                    *vertices.add(3 * t + k) = p.extend(0.0).to_array();
                }
                let base = 3 * t as u32;
                *indices.add(t) = [base, base + 1, base + 2];
            }
            rtcCommitGeometry(geom);
            assert_eq!(rtcAttachGeometry(handle, geom), 0);
            rtcReleaseGeometry(geom);
            let geom = rtcNewGeometry(device, GEOMETRY_SPHERE_POINT);
            let points =
                rtcSetNewGeometryBuffer(geom, BUFFER_VERTEX, 0, FORMAT_FLOAT4, 16, spheres.len())
                    as *mut [f32; 4];
            for (s, p) in spheres.iter().enumerate() {
                *points.add(s) = p.to_array();
            }
            rtcCommitGeometry(geom);
            assert_eq!(rtcAttachGeometry(handle, geom), 1);
            rtcReleaseGeometry(geom);
            rtcCommitScene(handle);
            assert_eq!(rtcGetDeviceError(device), 0, "Embree scene build");
            Self {
                device,
                scene: handle,
                prims,
            }
        }
    }

    /// Closest hit (`rtcIntersect1`): distance and torrey's primitive index.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut rh = RayHit1 {
            ray: ray1(ray),
            hit: Hit1 {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: INVALID_ID,
                geom_id: INVALID_ID,
                inst_id: [INVALID_ID],
            },
        };
        // SAFETY: a committed scene and a valid, aligned ray-hit record.
        unsafe { rtcIntersect1(self.scene, &mut context(0), &mut rh) };
        (rh.hit.geom_id != INVALID_ID).then(|| {
            (
                rh.ray.tfar,
                self.prims[rh.hit.geom_id as usize][rh.hit.prim_id as usize],
            )
        })
    }

    /// Any hit (`rtcOccluded1`).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut r = ray1(ray);
        // SAFETY: as in `intersect`.
        unsafe { rtcOccluded1(self.scene, &mut context(0), &mut r) };
        r.tfar < 0.0
    }

    /// Closest hits of eight rays from `origin` (`rtcIntersect8`, coherent): how many hit.
    #[inline]
    pub fn intersect8(&self, origin: Vec3A, dirs: &[Vec3A; 8]) -> usize {
        let mut rh = ray_hit_n(origin, dirs);
        // SAFETY: as in `intersect`; the packet record is 64-byte aligned.
        unsafe { rtcIntersect8(&Valid([-1; 8]), self.scene, &mut context(COHERENT), &mut rh) };
        rh.geom_id.iter().filter(|&&g| g != INVALID_ID).count()
    }

    /// Closest hits of sixteen rays from `origin` (`rtcIntersect16`, coherent).
    #[inline]
    pub fn intersect16(&self, origin: Vec3A, dirs: &[Vec3A; 16]) -> usize {
        let mut rh = ray_hit_n(origin, dirs);
        // SAFETY: as in `intersect8`.
        unsafe {
            rtcIntersect16(
                &Valid([-1; 16]),
                self.scene,
                &mut context(COHERENT),
                &mut rh,
            )
        };
        rh.geom_id.iter().filter(|&&g| g != INVALID_ID).count()
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: the handles were created in `new` and are released once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

/// `rtcInitIntersectContext` (an inline function of the C header) with `flags`.
fn context(flags: u32) -> Context {
    Context {
        flags,
        filter: std::ptr::null(),
        inst_id: [INVALID_ID],
    }
}

/// torrey's ray (t in (0, tmax)) as an Embree ray (t in [0, tfar]).
#[inline]
fn ray1(ray: &Ray) -> Ray1 {
    Ray1 {
        org: ray.origin.to_array(),
        tnear: 0.0,
        dir: ray.dir.to_array(),
        time: 0.0,
        tfar: ray.tmax,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

#[inline]
fn ray_hit_n<const N: usize>(origin: Vec3A, dirs: &[Vec3A; N]) -> RayHitN<N> {
    RayHitN {
        org: [[origin.x; N], [origin.y; N], [origin.z; N]],
        tnear: [0.0; N],
        dir: [dirs.map(|d| d.x), dirs.map(|d| d.y), dirs.map(|d| d.z)],
        time: [0.0; N],
        tfar: [f32::INFINITY; N],
        mask: [u32::MAX; N],
        id: [0; N],
        flags: [0; N],
        ng: [[0.0; N]; 3],
        u: [0.0; N],
        v: [0.0; N],
        prim_id: [INVALID_ID; N],
        geom_id: [INVALID_ID; N],
        inst_id: [INVALID_ID; N],
    }
}
