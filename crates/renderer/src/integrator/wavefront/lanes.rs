//! The surface stage's lane path: the bounce's surfaced paths whose shape [`LaneTable`] admits
//! (and whose light draw, if any, is a point on an area-sampled emitter, a point light's, a
//! constant background's numbers or an environment map's batched sample) are gathered in chunks
//! of the SIMD width into [`Chunk`]s, shaded by [`lane_kernel::shade`], and scattered back into
//! their path states, shadow rays and the live list in the order the scalar `shade` gives them.
//! One pass over the surfaced paths: the gather itself decides whether the lanes take a path,
//! and hands the others to the scalar `shade` at once; the two sets' lists are merged by path
//! index, which is the order of the surfaced list (it ascends, as the live list it comes from).

use super::lane_kernel::{self, Chunk};
use super::lane_table::{LaneLight, LaneTable};
use super::{PathState, ShadowRay};
use crate::accel::Simd;
use crate::integrator::{EnvStrategy, PathSettings};
use crate::lights::LightDraw;
use crate::ray::Ray;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use crate::textures::{ColorSource, TextureQuery};
use glam::Vec3A;
use std::sync::OnceLock;
use torrey_texture::Footprint;

/// Whether the surface stage uses the lanes: with AVX2 or AVX-512 ([`Simd::detect`]), where the
/// kernel is vectorised. The portable (SSE2) build of the kernel stays scalar (LLVM's cost model
/// declines to vectorise it) and is slower than the scalar `shade`, so it is only run by the
/// tests, or with `TORREY_WAVEFRONT_LANES=on`. `TORREY_WAVEFRONT_LANES=off` makes every path take
/// the scalar `shade` (the same bits; for measuring what the lanes gain).
pub(super) fn lanes_enabled() -> bool {
    static ON: OnceLock<bool> = OnceLock::new();
    *ON.get_or_init(|| {
        let var = std::env::var("TORREY_WAVEFRONT_LANES").unwrap_or_default();
        if var.eq_ignore_ascii_case("off") {
            return false;
        }
        var.eq_ignore_ascii_case("on") || Simd::detect() != Simd::Portable
    })
}

/// Whether the lanes shade path `path` at `hit` (the rule [`gather`] applies, for the tests):
/// its shape is in the table, and it is a mirror (which reads no light draw) or its light draw
/// is none, a point on a lane emitter, a point light's, a constant background's or an
/// environment map's drawn sample.
#[cfg(test)]
pub(super) fn lane_able(table: &LaneTable, path: &PathState, hit: &SurfaceHit) -> bool {
    let Some(shape) = table.shapes[hit.shape as usize] else {
        return false;
    };
    // A mirror connects to no light: any draw.
    (table.any_mirror && shape.mirror)
        || match path.light_draw {
            None => true,
            Some((li, LightDraw::MeshPoint { .. })) => {
                matches!(table.lights[li], Some(LaneLight::Area(_)))
            }
            // The lanes' sphere sampling assumes u.y in [0, 1], as the sampler's numbers are.
            Some((li, LightDraw::Deferred(u))) => match table.lights[li] {
                Some(LaneLight::Constant(_)) => (0.0..=1.0).contains(&u.y),
                Some(LaneLight::Point { .. }) => true,
                _ => false,
            },
            // An environment map's sample, drawn in lanes by `draw_env_lights` (a map sampled
            // on its own at shading time, `Deferred`, takes the scalar stage).
            Some((li, LightDraw::EnvSampled { .. })) => {
                matches!(table.lights[li], Some(LaneLight::Env))
            }
        }
}

/// What the lane path reads besides the paths.
#[derive(Clone, Copy)]
pub(super) struct LaneParams<'a> {
    pub table: &'a LaneTable,
    pub max_depth: u32,
    pub rr_depth: i32,
    pub hide_emitters: bool,
    pub light_select_pdf: f32,
    pub footprint_scale: f32,
    /// Ray cones filter something (textures, environment maps): the paths' cones are updated.
    pub track_cones: bool,
    /// Textures are filtered by the ray cone's footprint (`--mipmapping`).
    pub mipmapping: bool,
    /// The scene, for textured reflectances (its textures and mesh attributes).
    pub scene: &'a RenderScene,
    /// Lights at infinity are weighed by MIS (`EnvStrategy::ImportanceMis`).
    pub infinite_mis: bool,
}

impl<'a> LaneParams<'a> {
    /// The parameters of `scene` rendered with `settings`.
    pub fn new(
        scene: &'a RenderScene,
        settings: PathSettings,
        max_depth: u32,
        light_select_pdf: f32,
    ) -> Self {
        LaneParams {
            table: &scene.lanes,
            max_depth,
            rr_depth: settings.rr_depth,
            hide_emitters: scene.hide_emitters,
            light_select_pdf,
            footprint_scale: settings.footprint_scale,
            track_cones: settings.mipmapping && scene.uses_cones,
            mipmapping: settings.mipmapping,
            scene,
            infinite_mis: settings.env_strategy == EnvStrategy::ImportanceMis,
        }
    }
}

/// The chunks the lanes work in, kept from call to call (set up once per worker: initialising
/// a chunk per call cost a memset of a few kilobytes per bounce). Lanes past a short last
/// chunk hold an earlier path's numbers; the kernel computes on them and nothing reads them.
#[derive(Default)]
pub(super) struct LaneChunks {
    c16: Box<Chunk<16>>,
    c8: Box<Chunk<8>>,
}

/// The scalar surface stage of one path (`wavefront::shade` and where its outputs go), for the
/// surfaced paths the lanes do not take. Called through a pointer: one copy of the scalar code,
/// not one per SIMD level.
pub(super) type ScalarShade<'a> = dyn FnMut(&mut PathState, &SurfaceHit, u32) + 'a;

/// Shades the surfaced paths `indices` (ascending) at the SIMD level [`Simd::detect`] gives:
/// each path the lanes take (`lane_able`'s rule) is gathered into the chunk as it comes, and
/// the chunk shaded in lanes when full (and at the end), pushing the continuing paths onto `live` and their shadow
/// rays onto `shadow` in `indices`' order; every other path goes to `scalar` at once (the two
/// sets touch different paths, so the order between them changes nothing). Returns the count of
/// chunks run.
pub(super) fn shade_lanes(chunks: &mut LaneChunks, work: LaneWork) -> usize {
    shade_lanes_at(Simd::detect(), chunks, work)
}

/// One call of the lane stage: the batch's paths and hits, the surfaced paths to shade
/// (`indices`, ascending), and where their outputs go.
pub(super) struct LaneWork<'a, 'p, 's> {
    pub paths: &'a mut [PathState],
    pub hits: &'a [SurfaceHit],
    pub indices: &'a [u32],
    pub params: LaneParams<'p>,
    pub live: &'a mut Vec<u32>,
    pub shadow: &'a mut Vec<ShadowRay>,
    pub scalar: &'a mut ScalarShade<'s>,
}

/// [`shade_lanes`] at a given level (the tests run each level the CPU has).
pub(super) fn shade_lanes_at(simd: Simd, chunks: &mut LaneChunks, work: LaneWork) -> usize {
    // Without environment-map or point-light samples, or without mirrors, the kernel leaves
    // their selects out.
    match (work.params.table.env_or_point, work.params.table.any_mirror) {
        (true, true) => shade_lanes_with::<true, true>(simd, chunks, work),
        (true, false) => shade_lanes_with::<true, false>(simd, chunks, work),
        (false, true) => shade_lanes_with::<false, true>(simd, chunks, work),
        (false, false) => shade_lanes_with::<false, false>(simd, chunks, work),
    }
}

/// [`shade_lanes_at`] with the kernel for `EXTRA` and `MIRROR` (see [`lane_kernel::shade`]).
fn shade_lanes_with<const EXTRA: bool, const MIRROR: bool>(
    simd: Simd,
    chunks: &mut LaneChunks,
    work: LaneWork,
) -> usize {
    match simd {
        #[cfg(target_arch = "x86_64")]
        Simd::Avx512 if crate::accel::x86_64::avx512::available() => {
            // SAFETY: the CPU has AVX-512 F, BW and VL, AVX2 and FMA (checked).
            unsafe { run_avx512::<EXTRA, MIRROR>(&mut chunks.c16, work) }
        }
        #[cfg(target_arch = "x86_64")]
        Simd::Avx2 | Simd::Avx512 if crate::accel::x86_64::avx2::available() => {
            // SAFETY: the CPU has AVX2 and FMA (checked).
            unsafe { run_avx2::<EXTRA, MIRROR>(&mut chunks.c8, work) }
        }
        _ => run::<8, MIRROR>(
            &mut chunks.c8,
            work,
            lane_kernel::shade_portable::<EXTRA, MIRROR>,
        ),
    }
}

/// [`run`] over sixteen lanes, compiled for AVX-512 as a whole: the gather and scatter around
/// the kernel move single floats in and out of vectors with one instruction each
/// (`vextractps`, `vinsertps`; SSE2 takes a shuffle and a move).
///
/// # Safety
/// The CPU must have AVX-512 F, BW and VL, AVX2 and FMA (`accel::Simd::Avx512`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
unsafe fn run_avx512<const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<16>,
    work: LaneWork,
) -> usize {
    run::<16, MIRROR>(c, work, |c, lsp, mis| {
        // SAFETY: this function's features are the kernel's.
        unsafe { lane_kernel::shade_avx512::<EXTRA, MIRROR>(c, lsp, mis) }
    })
}

/// [`run`] over eight lanes, compiled for AVX2 as a whole (see [`run_avx512`]).
///
/// # Safety
/// The CPU must have AVX2 and FMA (`accel::Simd::Avx2` or better).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<8>,
    work: LaneWork,
) -> usize {
    run::<8, MIRROR>(c, work, |c, lsp, mis| {
        // SAFETY: this function's features are the kernel's.
        unsafe { lane_kernel::shade_avx2::<EXTRA, MIRROR>(c, lsp, mis) }
    })
}

/// Gathers the lane-able paths of `indices` `N` at a time, runs `kernel` on each chunk and
/// scatters it back; the others go to `scalar`. The shadow rays and live paths are appended
/// without a branch: each lane writes its entry at the lists' end and moves the end by its flag
/// (whether a lane connects or continues is data, which a branch mispredicts); the lists hold
/// room for every path until the end is set.
#[inline(always)]
fn run<const N: usize, const MIRROR: bool>(
    c: &mut Chunk<N>,
    work: LaneWork,
    kernel: impl Fn(&mut Chunk<N>, f32, bool),
) -> usize {
    let LaneWork {
        paths,
        hits,
        indices,
        params,
        live,
        shadow,
        scalar,
    } = work;
    let mut chunks = 0;
    let mut ends = (live.len(), shadow.len());
    live.resize(ends.0 + indices.len(), 0);
    shadow.resize(ends.1 + indices.len(), ShadowRay::default());
    let mut group = [0u32; N];
    let mut lanes = 0;
    for &i in indices {
        let hit = &hits[i as usize];
        if gather::<N, MIRROR>(c, lanes, &paths[i as usize], hit, params) {
            group[lanes] = i;
            lanes += 1;
            if lanes == N {
                finish::<N, MIRROR>(c, &group, paths, params, live, shadow, &mut ends, &kernel);
                chunks += 1;
                lanes = 0;
            }
        } else {
            scalar(&mut paths[i as usize], hit, i);
        }
    }
    if lanes > 0 {
        finish::<N, MIRROR>(
            c,
            &group[..lanes],
            paths,
            params,
            live,
            shadow,
            &mut ends,
            &kernel,
        );
        chunks += 1;
    }
    live.truncate(ends.0);
    shadow.truncate(ends.1);
    chunks
}

/// Runs `kernel` on `c`, whose lanes hold paths `group`, and scatters them back, writing their
/// live entries and shadow rays at `ends` (see [`run`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn finish<const N: usize, const MIRROR: bool>(
    c: &mut Chunk<N>,
    group: &[u32],
    paths: &mut [PathState],
    params: LaneParams,
    live: &mut [u32],
    shadow: &mut [ShadowRay],
    ends: &mut (usize, usize),
    kernel: &impl Fn(&mut Chunk<N>, f32, bool),
) {
    kernel(c, params.light_select_pdf, params.infinite_mis);
    for (l, &i) in group.iter().enumerate() {
        shadow[ends.1] = ShadowRay {
            path: i,
            origin: take(&c.s_origin, l),
            dir: take(&c.s_dir, l),
            tmax: c.s_tmax[l],
            contribution: take(&c.s_contribution, l),
        };
        ends.1 += c.shadow[l] as usize;
        live[ends.0] = i;
        ends.0 += c.alive[l] as usize;
        scatter::<N, MIRROR>(c, l, &mut paths[i as usize], params);
    }
}

#[inline(always)]
fn put<const N: usize>(v: &mut [[f32; N]; 3], l: usize, x: Vec3A) {
    v[0][l] = x.x;
    v[1][l] = x.y;
    v[2][l] = x.z;
}

#[inline(always)]
fn take<const N: usize>(v: &[[f32; N]; 3], l: usize) -> Vec3A {
    Vec3A::new(v[0][l], v[1][l], v[2][l])
}

/// Lane `l` of `c` from path `path` at `hit`, if the lanes take it (`lane_able`'s rule, decided
/// here with the lookups the gather needs anyway); false leaves lane `l` to the next path.
#[inline(always)]
fn gather<const N: usize, const MIRROR: bool>(
    c: &mut Chunk<N>,
    l: usize,
    path: &PathState,
    hit: &SurfaceHit,
    params: LaneParams,
) -> bool {
    let Some(shape) = &params.table.shapes[hit.shape as usize] else {
        return false;
    };
    c.has_light[l] = 1;
    match path.light_draw {
        None => c.has_light[l] = 0,
        // A mirror connects to no light: its draw, whatever it is, is not read.
        Some(_) if MIRROR && shape.mirror => c.has_light[l] = 0,
        Some((li, draw)) => match (draw, &params.table.lights[li]) {
            (LightDraw::MeshPoint { q, n }, Some(LaneLight::Area(e))) => {
                (c.infinite[l], c.env[l], c.point[l]) = (0, 0, 0);
                put(&mut c.q, l, q);
                put(&mut c.nq, l, n);
                put(&mut c.l_radiance, l, Vec3A::from_array(e.radiance));
                c.l_area[l] = e.area;
            }
            // The lanes' sphere sampling assumes u.y in [0, 1], as the sampler's numbers are.
            (LightDraw::Deferred(u), Some(LaneLight::Constant(radiance)))
                if (0.0..=1.0).contains(&u.y) =>
            {
                (c.infinite[l], c.env[l], c.point[l]) = (1, 0, 0);
                c.q[0][l] = u.x;
                c.q[1][l] = u.y;
                put(&mut c.l_radiance, l, Vec3A::from_array(*radiance));
            }
            (
                LightDraw::Deferred(_),
                Some(LaneLight::Point {
                    position,
                    intensity,
                }),
            ) => {
                // `PointLight::sample`'s radiance (the kernel repeats the rest).
                let position = Vec3A::from_array(*position);
                let dist2 = (position - hit.p).length_squared();
                (c.infinite[l], c.env[l], c.point[l]) = (0, 0, 1);
                put(&mut c.q, l, position);
                put(&mut c.l_radiance, l, Vec3A::from_array(*intensity) / dist2);
            }
            // An environment map's sample, drawn in lanes by `draw_env_lights` (a map sampled
            // on its own at shading time, `Deferred`, takes the scalar stage).
            (LightDraw::EnvSampled { wi, radiance, pdf }, Some(LaneLight::Env)) => {
                (c.infinite[l], c.env[l], c.point[l]) = (1, 1, 0);
                put(&mut c.q, l, wi);
                put(&mut c.l_radiance, l, radiance);
                c.l_area[l] = pdf;
            }
            _ => return false,
        },
    }
    put(&mut c.p, l, hit.p);
    put(&mut c.ng, l, hit.ng);
    put(&mut c.ns, l, hit.ns);
    c.t[l] = hit.t;
    put(&mut c.dir, l, path.ray.dir);
    put(&mut c.throughput, l, path.throughput);
    put(&mut c.result, l, path.result);
    c.prev_pdf[l] = path.prev_bsdf_pdf;
    c.prev_delta[l] = path.prev_delta as u32;
    put(&mut c.prev_p, l, path.prev_p);
    c.eta[l] = path.eta;
    c.u_dir[0][l] = path.u_dir.x;
    c.u_dir[1][l] = path.u_dir.y;
    c.u_rr[l] = path.u_rr;
    c.last[l] = (path.depth + 1 >= params.max_depth) as u32;
    c.roulette[l] = ((path.depth + 1) as i32 >= params.rr_depth) as u32;
    let reflectance = match shape.texture {
        None => Vec3A::from_array(shape.reflectance),
        // The scalar `shade`'s lookup (a last segment shades nothing: no lookup).
        Some(_) if c.last[l] != 0 => Vec3A::ZERO,
        Some(texture) => {
            let footprint = if params.mipmapping {
                let cone = if params.track_cones {
                    path.cone.at_distance(hit.t)
                } else {
                    path.cone
                };
                cone.footprint(path.ray.dir, hit.ng, hit.dpdu, hit.dpdv)
            } else {
                Footprint::POINT
            };
            let scene = params.scene;
            let attribute_point = scene.attribute_point(hit);
            TextureQuery {
                textures: &scene.textures,
                at: attribute_point.as_ref(),
                uv: hit.uv,
                footprint,
            }
            .color(ColorSource::Texture(texture))
        }
    };
    put(&mut c.reflectance, l, reflectance);
    c.two_sided[l] = shape.two_sided as u32;
    if MIRROR {
        c.mirror[l] = shape.mirror as u32;
    }
    let visible = path.depth > 0 || !params.hide_emitters;
    match (shape.emitter, visible) {
        (Some(e), true) => {
            c.emits[l] = 1;
            put(&mut c.le, l, Vec3A::from_array(e.radiance));
            c.le_area[l] = e.area;
        }
        _ => c.emits[l] = 0,
    }
    true
}

/// Lane `l` of `c` back into its path. A path the lane ends (`cont` false) is never read again
/// but for its radiance, so the continuation is written whatever `cont` (no branch), all but the
/// depth, which counts the bounces taken (as the scalar `shade` leaves it).
#[inline(always)]
fn scatter<const N: usize, const MIRROR: bool>(
    c: &Chunk<N>,
    l: usize,
    path: &mut PathState,
    params: LaneParams,
) {
    path.result = take(&c.result, l);
    // Lane surfaces (diffuse, mirror) are never `null` crossings.
    path.valid = true;
    // The scalar `shade`'s bookkeeping of a diffuse bounce (roughness 1, eta 1), or of a
    // mirror's (a delta lobe, eta 1: the cone's spread and the specular chain unchanged).
    let delta = MIRROR && c.mirror[l] != 0;
    if params.track_cones {
        path.cone = path.cone.at_distance(c.t[l]);
        let spread = path.cone.spread;
        path.cone.spread = if delta {
            spread
        } else {
            spread + params.footprint_scale
        };
    }
    path.specular_chain &= delta;
    path.throughput = take(&c.new_throughput, l);
    path.prev_bsdf_pdf = c.new_pdf[l];
    path.prev_delta = delta;
    path.prev_p = take(&c.p, l);
    path.ray = Ray {
        origin: take(&c.new_origin, l),
        dir: take(&c.new_dir, l),
        tmax: f32::INFINITY,
    };
    path.depth += c.cont[l];
}

/// Merges `b` into `a`, both ascending by `key`: the order the scalar stage gives (`b` is left
/// in an unspecified state).
pub(super) fn merge_by<T: Copy>(
    a: &mut Vec<T>,
    b: &mut Vec<T>,
    tmp: &mut Vec<T>,
    key: impl Fn(&T) -> u32,
) {
    if b.is_empty() {
        return;
    }
    if a.is_empty() {
        // Only `b` (every path took the lanes): the lists trade places, nothing is copied.
        std::mem::swap(a, b);
        return;
    }
    tmp.clear();
    tmp.reserve(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if key(&a[i]) <= key(&b[j]) {
            tmp.push(a[i]);
            i += 1;
        } else {
            tmp.push(b[j]);
            j += 1;
        }
    }
    tmp.extend_from_slice(&a[i..]);
    tmp.extend_from_slice(&b[j..]);
    std::mem::swap(a, tmp);
}

#[cfg(test)]
mod tests {
    use super::super::{shade, PathSettings};
    use super::*;
    use crate::integrator::EnvStrategy;
    use crate::scene::RenderScene;
    use glam::Vec2;
    use torrey_testkit::Rng;
    use torrey_texture::RayCone;

    /// Diffuse shapes one- and two-sided (a mesh, a sphere, a disk), mirrors (a one-sided
    /// sphere, a two-sided textured rectangle), two emitters sampled by area (a one-sided
    /// rectangle and a two-sided disk), a constant background, an environment map, a point
    /// light, a spot light (scalar) and a plastic box (scalar), inside a closed room so random
    /// rays hit from both sides.
    fn scene() -> RenderScene {
        let xml = r#"<scene version="3.0.0">
            <sensor type="perspective">
                <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
            </sensor>
            <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5, 0.4, 0.3"/></bsdf>
            <bsdf type="twosided" id="both"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.7, 0.1"/></bsdf></bsdf>
            <shape type="cube"><transform name="toWorld"><scale value="3"/></transform><ref id="both"/></shape>
            <shape type="obj"><string name="filename" value="meshes/torus.obj"/>
                <transform name="toWorld"><scale value="0.6"/><translate x="-1" y="0.3"/></transform><ref id="grey"/></shape>
            <shape type="sphere"><point name="center" x="1" y="-1" z="0.5"/><float name="radius" value="0.6"/><ref id="both"/></shape>
            <shape type="rectangle"><transform name="toWorld"><scale value="0.7"/><rotate y="1" angle="-70"/><translate x="2" y="1.2"/></transform>
                <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="../textures/checker_fine.png"/></texture></bsdf></shape>
            <shape type="sphere"><point name="center" x="-1.2" y="-1.6" z="-1.2"/><float name="radius" value="0.8"/>
                <bsdf type="twosided"><bsdf type="diffuse"><texture name="reflectance" type="checkerboard"><float name="uscale" value="6"/></texture></bsdf></bsdf></shape>
            <shape type="cube"><transform name="toWorld"><scale value="0.4"/><translate x="1" y="1" z="-1"/></transform>
                <bsdf type="plastic"/></shape>
            <shape type="sphere"><point name="center" x="1.7" y="-1.8" z="-1.6"/><float name="radius" value="0.9"/>
                <bsdf type="mirror"><rgb name="reflectance" value="0.9, 0.6, 0.3"/></bsdf></shape>
            <shape type="rectangle"><transform name="toWorld"><scale value="1.1"/><rotate x="1" angle="35"/><translate x="-1.4" y="1.4" z="-1.7"/></transform>
                <bsdf type="twosided"><bsdf type="mirror"><texture name="reflectance" type="checkerboard"><float name="uscale" value="4"/></texture></bsdf></bsdf></shape>
            <shape type="rectangle">
                <transform name="toWorld"><rotate x="1" angle="90"/><translate y="2.5"/></transform>
                <emitter type="area"><rgb name="radiance" value="4, 3, 2"/></emitter><ref id="grey"/>
            </shape>
            <shape type="disk">
                <transform name="toWorld"><scale value="0.5"/><rotate y="1" angle="60"/><translate x="-2" z="1"/></transform>
                <emitter type="area"><rgb name="radiance" value="1, 2, 5"/></emitter><ref id="both"/>
            </shape>
            <emitter type="point"><point name="position" x="0" y="2" z="2"/><rgb name="intensity" value="3, 3, 3"/></emitter>
            <emitter type="spot"><rgb name="intensity" value="2, 3, 4"/><float name="cutoff_angle" value="40"/></emitter>
            <emitter type="constant"><rgb name="radiance" value="0.3, 0.4, 0.5"/></emitter>
            <emitter type="envmap"><string name="filename" value="../textures/sky_sun.exr"/>
                <float name="scale" value="0.01"/></emitter>
        </scene>"#;
        crate::scene::scene_from_xml(xml, 8, 8)
    }

    /// An edge-biased number in [0, 1): exact 0, 1/2 (the disk map's centre), just under 1, or
    /// uniform.
    fn unit(rng: &mut Rng) -> f32 {
        match rng.f32() {
            x if x < 0.05 => 0.0,
            x if x < 0.1 => 0.5,
            x if x < 0.15 => 1.0f32.next_down(),
            _ => rng.f32(),
        }
    }

    fn bits(v: Vec3A) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// Light `index`'s draw with numbers `u`: an environment map's is mostly drawn ahead as the
    /// wavefront's `draw_env_lights` does (`pick` < 0.8; a tenth of those drew nothing, density
    /// 0), else deferred (the scalar stage's).
    fn draw(scene: &RenderScene, index: usize, u: Vec2, pick: f32) -> LightDraw {
        let light = &scene.lights[index];
        let crate::lights::Light::Env(env) = light else {
            return light.draw(u);
        };
        match env.sample(u, false) {
            Some(s) if pick < 0.72 => LightDraw::EnvSampled {
                wi: s.wi,
                radiance: s.radiance,
                pdf: s.pdf,
            },
            _ if pick < 0.8 => LightDraw::EnvSampled {
                wi: Vec3A::ZERO,
                radiance: Vec3A::ZERO,
                pdf: 0.0,
            },
            _ => light.draw(u),
        }
    }

    /// Random paths at random hits: the lanes, handing the paths they do not take to the scalar
    /// `shade`, give what the scalar `shade` gives on every path, bit for bit (path state, shadow
    /// rays, live list, in order), at every SIMD level the CPU runs; they take exactly the
    /// paths `lane_able` admits.
    #[test]
    fn lanes_shade_as_the_scalar_stage() {
        let scene = scene();
        assert!(scene.lanes.any);
        let mut levels = vec![Simd::Portable];
        #[cfg(target_arch = "x86_64")]
        {
            if crate::accel::x86_64::avx2::available() {
                levels.push(Simd::Avx2);
            }
            if crate::accel::x86_64::avx512::available() {
                levels.push(Simd::Avx512);
            }
        }
        let mut scene = scene;
        for env_strategy in [
            EnvStrategy::ImportanceMis,
            EnvStrategy::Importance,
            EnvStrategy::Uniform,
        ] {
            check_lanes(&scene, &levels, env_strategy, true);
        }
        // Textures looked up at their finest level.
        check_lanes(&scene, &levels, EnvStrategy::ImportanceMis, false);
        // Cones not tracked (as in a scene where nothing filters).
        scene.uses_cones = false;
        check_lanes(&scene, &levels, EnvStrategy::ImportanceMis, true);
    }

    fn check_lanes(
        scene: &RenderScene,
        levels: &[Simd],
        env_strategy: EnvStrategy,
        mipmapping: bool,
    ) {
        let max_depth = 6;
        let settings = PathSettings {
            max_depth: max_depth as i32,
            rr_depth: 3,
            mipmapping,
            footprint_scale: 0.25,
            env_strategy,
        };
        let light_select_pdf = 1.0 / scene.lights.len() as f32;
        let mut rng = Rng::new(21);
        let (mut paths, mut hits) = (Vec::new(), Vec::new());
        let (mut lane_count, mut back_views, mut emitted, mut background) = (0, 0, 0, 0);
        let (mut env, mut textured, mut point) = (0, 0, 0);
        let (mut mirrors, mut mirror_backs, mut mirror_edges) = (0, 0, 0);
        while paths.len() < 3000 {
            let origin = Vec3A::new(
                rng.f32() * 5.8 - 2.9,
                rng.f32() * 5.8 - 2.9,
                rng.f32() * 5.8 - 2.9,
            );
            let dir = Vec3A::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5).normalize();
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            let Some(mut hit) = scene.intersect(&ray) else {
                continue;
            };
            let on_mirror = scene.lanes.shapes[hit.shape as usize].is_some_and(|s| s.mirror);
            // Edge views of mirrors: wo exactly in the tangent plane (both signs of zero),
            // along the normal, and normals of either z sign (the frame's two branches); the
            // kernel and `shade` need not see consistent geometry, only the same numbers.
            let mut ray = ray;
            if on_mirror && paths.len() % 16 == 0 {
                let k = paths.len() / 16 % 5;
                let (n, d) = [
                    (Vec3A::Z, Vec3A::X),
                    (Vec3A::NEG_Z, Vec3A::NEG_Y),
                    (Vec3A::Y, Vec3A::NEG_Y),
                    (Vec3A::NEG_Y, Vec3A::new(0.6, 0.0, 0.8)),
                    (Vec3A::new(0.0, 0.6, -0.8), Vec3A::X),
                ][k];
                hit.ns = n;
                ray.dir = d;
                mirror_edges += 1;
            }
            let light_index = (rng.f32() * scene.lights.len() as f32) as usize;
            let depth = (rng.f32() * max_depth as f32) as u32;
            let path = PathState {
                sample: paths.len() as u32,
                requests: 0,
                ray,
                cone: RayCone::from_pixel(0.01),
                throughput: Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 2.0,
                result: Vec3A::new(rng.f32(), rng.f32(), rng.f32()),
                prev_bsdf_pdf: match rng.f32() {
                    x if x < 0.1 => 0.0,
                    x if x < 0.2 => f32::INFINITY,
                    _ => rng.f32() * 3.0,
                },
                prev_delta: rng.f32() < 0.3,
                prev_p: Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 4.0 - 2.0,
                specular_chain: rng.f32() < 0.5,
                eta: if rng.f32() < 0.2 { 1.5 } else { 1.0 },
                depth,
                valid: rng.f32() < 0.5,
                traced: false,
                u_dir: Vec2::new(unit(&mut rng), unit(&mut rng)),
                u_lobe: rng.f32(),
                u_rr: unit(&mut rng),
                light_draw: (depth + 1 < max_depth && rng.f32() < 0.9).then(|| {
                    let u = Vec2::new(unit(&mut rng), unit(&mut rng));
                    (light_index, draw(scene, light_index, u, rng.f32()))
                }),
            };
            if lane_able(&scene.lanes, &path, &hit) {
                lane_count += 1;
                back_views += (hit.ns.dot(ray.dir) > 0.0) as u32;
                emitted += scene.shapes[hit.shape as usize].area_light.is_some() as u32;
                background += matches!(path.light_draw, Some((_, LightDraw::Deferred(_)))) as u32;
                env += matches!(path.light_draw, Some((_, LightDraw::EnvSampled { .. }))) as u32;
                point += matches!(
                    path.light_draw.map(|d| &scene.lights[d.0]),
                    Some(crate::lights::Light::Point(_))
                ) as u32;
                textured += scene.lanes.shapes[hit.shape as usize]
                    .is_some_and(|s| s.texture.is_some()) as u32;
                mirrors += on_mirror as u32;
                mirror_backs += (on_mirror && hit.ns.dot(ray.dir) > 0.0) as u32;
            }
            paths.push(path);
            hits.push(hit);
        }
        // Enough of each case: lane paths, paths seeing a back, emitters hit, background
        // samples (and point lights'), environment-map samples, textured surfaces, mirrors
        // (seen from the back, at the edges).
        assert!(
            lane_count > 1500
                && back_views > 300
                && emitted > 50
                && background > 200
                && env > 150
                && textured > 100
                && point > 150
                && mirrors > 120
                && mirror_backs > 40
                && mirror_edges > 8,
            "{lane_count} {back_views} {emitted} {background} {env} {textured} {point} \
             {mirrors} {mirror_backs} {mirror_edges}"
        );
        let indices: Vec<u32> = (0..paths.len() as u32)
            .filter(|&i| lane_able(&scene.lanes, &paths[i as usize], &hits[i as usize]))
            .collect();

        // The scalar stage on every path (the lanes' run hands it the paths they do not take).
        let all: Vec<u32> = (0..paths.len() as u32).collect();
        let mut want = paths.clone();
        let (mut want_live, mut want_shadow) = (Vec::new(), Vec::new());
        for &i in &all {
            let hit = &hits[i as usize];
            want_shadow.extend(shade(
                scene,
                &mut want[i as usize],
                hit,
                settings,
                max_depth,
                light_select_pdf,
                i,
                &mut want_live,
            ));
        }
        assert!(want_shadow.len() > 600 && want_live.len() > 600);
        let params = LaneParams::new(scene, settings, max_depth, light_select_pdf);
        // One set of chunks for all levels and runs, as a worker keeps them.
        let mut lane_chunks = LaneChunks::default();
        // The kernels without the environment-map and point-light selects, without the
        // mirror's, or without both, on the lane paths that need none of them only (the scalar
        // stage is not called).
        let extra_path = |i: u32| {
            let draw = paths[i as usize].light_draw;
            matches!(draw, Some((_, LightDraw::EnvSampled { .. })))
                || matches!(
                    draw.map(|d| &scene.lights[d.0]),
                    Some(crate::lights::Light::Point(_))
                )
        };
        let mirror_path =
            |i: u32| scene.lanes.shapes[hits[i as usize].shape as usize].is_some_and(|s| s.mirror);
        let mut variants = vec![(
            params.table.clone(),
            all.clone(),
            indices.len(),
            want_live.clone(),
            want_shadow.clone(),
        )];
        for (extra, mirror) in [(false, true), (true, false), (false, false)] {
            let mut table = scene.lanes.clone();
            table.env_or_point = extra;
            table.any_mirror = mirror;
            let kept: Vec<u32> = indices
                .iter()
                .copied()
                .filter(|&i| (extra || !extra_path(i)) && (mirror || !mirror_path(i)))
                .collect();
            let is_kept = |i: &u32| kept.binary_search(i).is_ok();
            let kept_live: Vec<u32> = want_live.iter().copied().filter(is_kept).collect();
            let kept_shadow: Vec<ShadowRay> = want_shadow
                .iter()
                .filter(|r| is_kept(&r.path))
                .copied()
                .collect();
            assert!(kept.len() > 400 && kept.len() < indices.len());
            let count = kept.len();
            variants.push((table, kept, count, kept_live, kept_shadow));
        }
        for (table, passed, lane_count, want_live, want_shadow) in &variants {
            let params = LaneParams { table, ..params };
            let lane_count = *lane_count;
            for &simd in levels {
                let mut got = paths.clone();
                let (mut live, mut shadow) = (Vec::new(), Vec::new());
                let (mut scalar_live, mut scalar_shadow) = (Vec::new(), Vec::new());
                let mut scalar_calls = 0;
                let work = LaneWork {
                    paths: &mut got,
                    hits: &hits,
                    indices: passed,
                    params,
                    live: &mut live,
                    shadow: &mut shadow,
                    scalar: &mut |path, hit, i| {
                        scalar_calls += 1;
                        scalar_shadow.extend(shade(
                            scene,
                            path,
                            hit,
                            settings,
                            max_depth,
                            light_select_pdf,
                            i,
                            &mut scalar_live,
                        ));
                    },
                };
                let chunks = shade_lanes_at(simd, &mut lane_chunks, work);
                assert_eq!(scalar_calls, passed.len() - lane_count, "{simd:?}");
                let mut tmp = Vec::new();
                merge_by(&mut scalar_live, &mut live, &mut tmp, |&i| i);
                let mut tmp = Vec::new();
                merge_by(&mut scalar_shadow, &mut shadow, &mut tmp, |r| r.path);
                let (live, shadow) = (scalar_live, scalar_shadow);
                let width = if simd == Simd::Avx512 { 16 } else { 8 };
                assert_eq!(chunks, lane_count.div_ceil(width), "{simd:?}");
                assert_eq!(live, *want_live, "{simd:?}");
                assert_eq!(shadow.len(), want_shadow.len(), "{simd:?}");
                for (s, w) in shadow.iter().zip(want_shadow.iter()) {
                    assert_eq!(s.path, w.path, "{simd:?}");
                    assert_eq!(
                        (
                            bits(s.origin),
                            bits(s.dir),
                            s.tmax.to_bits(),
                            bits(s.contribution)
                        ),
                        (
                            bits(w.origin),
                            bits(w.dir),
                            w.tmax.to_bits(),
                            bits(w.contribution)
                        ),
                        "{simd:?} path {}",
                        s.path
                    );
                }
                for &i in passed.iter() {
                    let (g, w) = (&got[i as usize], &want[i as usize]);
                    let what = format!("{simd:?} path {i}");
                    assert_eq!(bits(g.result), bits(w.result), "{what}");
                    assert_eq!(g.depth, w.depth, "{what}");
                    assert_eq!(g.valid, w.valid, "{what}");
                    if g.depth == paths[i as usize].depth {
                        continue; // ended here: only its radiance counts
                    }
                    assert_eq!(bits(g.throughput), bits(w.throughput), "{what}");
                    assert_eq!(bits(g.ray.origin), bits(w.ray.origin), "{what}");
                    assert_eq!(bits(g.ray.dir), bits(w.ray.dir), "{what}");
                    assert_eq!(g.ray.tmax, w.ray.tmax, "{what}");
                    assert_eq!(
                        g.prev_bsdf_pdf.to_bits(),
                        w.prev_bsdf_pdf.to_bits(),
                        "{what}"
                    );
                    assert_eq!(
                        (g.prev_delta, g.specular_chain),
                        (w.prev_delta, w.specular_chain),
                        "{what}"
                    );
                    assert_eq!(bits(g.prev_p), bits(w.prev_p), "{what}");
                    assert_eq!(g.eta.to_bits(), w.eta.to_bits(), "{what}");
                    assert_eq!(g.cone, w.cone, "{what}");
                }
            }
        }
    }

    /// The table admits the constant and textured diffuse shapes (emitting or not) and not the
    /// plastic one, the area, point, constant and environment lights and not the spot light;
    /// with a spot light the lanes do not cover the scene's lights (`PathLoop::Auto` keeps the
    /// scalar loop).
    #[test]
    fn the_table_admits_diffuse_and_area_point_or_infinite_lights() {
        let scene = scene();
        let admitted: Vec<bool> = scene.lanes.shapes.iter().map(Option::is_some).collect();
        assert_eq!(
            admitted,
            [true, true, true, true, true, false, true, true, true, true]
        );
        let mirrors = scene.lanes.shapes.iter().flatten().filter(|s| s.mirror);
        assert_eq!(mirrors.count(), 2);
        assert!(scene.lanes.any_mirror);
        let textured = scene
            .lanes
            .shapes
            .iter()
            .flatten()
            .filter(|s| s.texture.is_some());
        assert_eq!(textured.count(), 3);
        let emitting = scene
            .lanes
            .shapes
            .iter()
            .flatten()
            .filter(|s| s.emitter.is_some());
        assert_eq!(emitting.count(), 2);
        let lights: Vec<bool> = scene
            .lights
            .iter()
            .zip(&scene.lanes.lights)
            .map(|(l, t)| {
                assert_eq!(t.is_some(), !matches!(l, crate::lights::Light::Spot(_)));
                t.is_some()
            })
            .collect();
        assert_eq!(lights.len(), 6);
        assert!(scene.lanes.any && !scene.lanes.covers_lights && scene.lanes.env_or_point);
    }

    /// Merging keeps both lists' elements in ascending order.
    #[test]
    fn merge_interleaves_by_key() {
        let mut a = vec![1u32, 4, 5, 9];
        let mut tmp = Vec::new();
        merge_by(&mut a, &mut vec![0, 2, 3, 10], &mut tmp, |&x| x);
        assert_eq!(a, [0, 1, 2, 3, 4, 5, 9, 10]);
        merge_by(&mut a, &mut Vec::new(), &mut tmp, |&x| x);
        assert_eq!(a.len(), 8);
        let mut empty = Vec::new();
        merge_by(&mut empty, &mut vec![3, 7], &mut tmp, |&x| x);
        assert_eq!(empty, [3, 7]);
    }
}
