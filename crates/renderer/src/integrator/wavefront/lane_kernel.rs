//! The surface stage's maths for up to `N` paths at once, in structure-of-arrays form: each
//! field holds one value per lane, and the kernel is one loop over the lanes with no branch (the
//! scalar code's branches are selects), which LLVM vectorises at the width the caller's target
//! features allow (16 lanes with AVX-512, 8 with AVX2, 4 with SSE2).
//!
//! It repeats `wavefront::shade` for a `diffuse` lit by an area light sampled by area, a point
//! light, a constant background or an environment map's drawn sample, and for a torrey `mirror`
//! (what [`super::lane_table`] admits), operation for operation and in the same order: emission
//! and its MIS weight, the shading frame, the BSDF sample (cosine-weighted, or the mirror's
//! reflection weighted by Schlick's Fresnel), the light connection with its shadow ray (none
//! for the mirror, a delta lobe), the continuation ray and Russian roulette. Rust never fuses a multiply
//! and an add, so the lanes give the scalar code's bits (tested against it).

// Comparisons are written `!(x > 0.0)` on purpose, as the scalar code's: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdfs::mirror_sample_select;
use crate::sampling::{
    power_heuristic_select, square_to_cosine_hemisphere_select, square_to_uniform_sphere_select,
    uniform_sphere_pdf,
};
use std::f32::consts::FRAC_1_PI;

/// Three coordinates, one array of lanes each.
pub(super) type Lanes3<const N: usize> = [[f32; N]; 3];

/// One chunk of paths: what the kernel reads (the hit, the path's state and draws, the shape's
/// material and emitter, the drawn light point) and what it writes. Flags are `u32` (0 or 1),
/// not `bool`: with byte-wide flags LLVM's cost model keeps the AVX2 loop scalar.
#[derive(Clone, Copy)]
pub(super) struct Chunk<const N: usize> {
    // In: the hit.
    pub p: Lanes3<N>,
    pub ng: Lanes3<N>,
    pub ns: Lanes3<N>,
    pub t: [f32; N],
    /// The ray that found the hit.
    pub dir: Lanes3<N>,
    // In: the path.
    pub throughput: Lanes3<N>,
    pub prev_pdf: [f32; N],
    pub prev_delta: [u32; N],
    pub prev_p: Lanes3<N>,
    pub eta: [f32; N],
    pub u_dir: [[f32; N]; 2],
    pub u_rr: [f32; N],
    /// This hit ends the path (its last segment): emission only.
    pub last: [u32; N],
    /// The continuation faces Russian roulette (its depth reaches `rr_depth`).
    pub roulette: [u32; N],
    // In: the material and the hit shape's emission (radiance zero: nothing added).
    pub reflectance: Lanes3<N>,
    pub two_sided: [u32; N],
    /// The material is a `mirror` (else a `diffuse`); read with the kernel's `MIRROR` only.
    pub mirror: [u32; N],
    /// The shape emits and emitters are visible at this depth.
    pub emits: [u32; N],
    pub le: Lanes3<N>,
    pub le_area: [f32; N],
    // In: the drawn light point (`has_light` false: no light sample), or with `infinite` the
    // constant background's numbers (in `q`'s x and y), or with `infinite` and `env` an
    // environment map's drawn direction (in `q`) and density (in `l_area`).
    /// With `point` (not `infinite`): a point light at `q`, its radiance at `p` in `l_radiance`.
    pub has_light: [u32; N],
    pub infinite: [u32; N],
    pub env: [u32; N],
    pub point: [u32; N],
    pub q: Lanes3<N>,
    pub nq: Lanes3<N>,
    pub l_radiance: Lanes3<N>,
    pub l_area: [f32; N],
    // In and out: the path's radiance (emission added).
    pub result: Lanes3<N>,
    // Out: the shadow ray.
    pub shadow: [u32; N],
    pub s_origin: Lanes3<N>,
    pub s_dir: Lanes3<N>,
    pub s_tmax: [f32; N],
    pub s_contribution: Lanes3<N>,
    // Out: the continuation (`cont` false: the path ends here; `alive` false: roulette ended it
    // after the continuation was set up).
    pub cont: [u32; N],
    pub alive: [u32; N],
    pub new_throughput: Lanes3<N>,
    pub new_pdf: [f32; N],
    pub new_origin: Lanes3<N>,
    pub new_dir: Lanes3<N>,
}

impl<const N: usize> Default for Chunk<N> {
    fn default() -> Self {
        let z3 = [[0.0; N]; 3];
        Chunk {
            p: z3,
            ng: z3,
            ns: [[0.0; N], [0.0; N], [1.0; N]],
            t: [0.0; N],
            dir: z3,
            throughput: z3,
            prev_pdf: [0.0; N],
            prev_delta: [1; N],
            prev_p: z3,
            eta: [1.0; N],
            u_dir: [[0.5; N]; 2],
            u_rr: [0.0; N],
            last: [1; N],
            roulette: [0; N],
            reflectance: z3,
            two_sided: [0; N],
            mirror: [0; N],
            emits: [0; N],
            le: z3,
            le_area: [1.0; N],
            has_light: [0; N],
            infinite: [0; N],
            env: [0; N],
            point: [0; N],
            q: z3,
            nq: z3,
            l_radiance: z3,
            l_area: [1.0; N],
            result: z3,
            shadow: [0; N],
            s_origin: z3,
            s_dir: z3,
            s_tmax: [0.0; N],
            s_contribution: z3,
            cont: [0; N],
            alive: [0; N],
            new_throughput: z3,
            new_pdf: [0.0; N],
            new_origin: z3,
            new_dir: z3,
        }
    }
}

/// glam's `Vec3A::dot` order: (x + y) + z.
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// glam's `Vec3A::max_element` (SSE `maxps`: the second operand unless the first is greater).
#[inline(always)]
fn max_element(v: [f32; 3]) -> f32 {
    let m = if v[0] > v[1] { v[0] } else { v[1] };
    if m > v[2] {
        m
    } else {
        v[2]
    }
}

#[inline(always)]
fn get<const N: usize>(v: &Lanes3<N>, l: usize) -> [f32; 3] {
    [v[0][l], v[1][l], v[2][l]]
}

#[inline(always)]
fn set<const N: usize>(v: &mut Lanes3<N>, l: usize, x: [f32; 3]) {
    v[0][l] = x[0];
    v[1][l] = x[1];
    v[2][l] = x[2];
}

#[inline(always)]
fn select3(c: bool, a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        if c { a[0] } else { b[0] },
        if c { a[1] } else { b[1] },
        if c { a[2] } else { b[2] },
    ]
}

#[inline(always)]
fn mul3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

#[inline(always)]
fn scale3(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `ray::offset_origin`.
#[inline(always)]
fn offset_origin(p: [f32; 3], ng: [f32; 3], dir: [f32; 3]) -> [f32; 3] {
    let scale = (max_element([p[0].abs(), p[1].abs(), p[2].abs()]) + 1.0) * 2e-5;
    let flip = dot(ng, dir) < 0.0;
    let n = select3(flip, [-ng[0], -ng[1], -ng[2]], ng);
    [
        p[0] + n[0] * scale,
        p[1] + n[1] * scale,
        p[2] + n[2] * scale,
    ]
}

/// The surface stage for every lane of `c` (see the module's documentation): `light_select_pdf`
/// is the scene's, `infinite_mis` whether lights at infinity are weighed by MIS. `EXTRA` false:
/// no lane holds an environment map's or a point light's sample (their selects compile away:
/// cbox's kernel was 6% more instructions with them). `MIRROR` false: no lane is a mirror (its
/// selects compile away likewise).
#[inline(always)]
pub(super) fn shade<const N: usize, const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<N>,
    light_select_pdf: f32,
    infinite_mis: bool,
) {
    for l in 0..N {
        let p = get(&c.p, l);
        let ng = get(&c.ng, l);
        let d = get(&c.dir, l);
        let wo = [-d[0], -d[1], -d[2]];
        let throughput = get(&c.throughput, l);

        // Emission of the hit shape, weighted against the light sample that could have found it
        // (`AreaLight::pdf_hit` of an area-sampled emitter).
        let emitted = c.emits[l] != 0 && dot(ng, wo) > 0.0;
        let cos_e = dot(ng, d).abs();
        let t = c.t[l];
        let pdf_e = if cos_e == 0.0 {
            0.0
        } else {
            t * t / (cos_e * c.le_area[l])
        } * light_select_pdf;
        let w_e = if c.prev_delta[l] != 0 {
            1.0
        } else {
            power_heuristic_select(c.prev_pdf[l], pdf_e)
        };
        let e = scale3(mul3(throughput, get(&c.le, l)), w_e);
        let result = get(&c.result, l);
        set(
            &mut c.result,
            l,
            select3(
                emitted,
                [result[0] + e[0], result[1] + e[1], result[2] + e[2]],
                result,
            ),
        );
        let shading = c.last[l] == 0;

        // The shading frame (`Frame::from_normal`) and wo in it.
        let n = get(&c.ns, l);
        let sign = 1.0f32.copysign(n[2]);
        let a = -1.0 / (sign + n[2]);
        let b = n[0] * n[1] * a;
        let s = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
        let tt = [b, sign + n[1] * n[1] * a, -n[1]];
        let wo_z = dot(wo, n);
        // The side seen: a two-sided material mirrors a back view to its front.
        let mirrored = c.two_sided[l] != 0 && wo_z < 0.0;
        let wo_bz = if mirrored { -wo_z } else { wo_z };
        let front = wo_bz > 0.0;
        let reflectance = get(&c.reflectance, l);
        let mirror = MIRROR && c.mirror[l] != 0;

        // The light sample (`AreaLight::connect_point`, `Diffuse::eval` and `pdf`, MIS, and
        // `path::shadow_ray`).
        // A point on an area light (`AreaLight::connect_point`), a direction to the constant
        // background (`ConstantLight::sample`) or an environment map's drawn direction
        // (`Light::connect` of `LightDraw::EnvSampled`).
        let infinite = c.infinite[l] != 0;
        let env = EXTRA && c.env[l] != 0;
        // A point light (`PointLight::sample`): a delta sample (pdf 1, no MIS); its radiance,
        // intensity / dist², is the gather's (a division only where there is a point light).
        let point = EXTRA && c.point[l] != 0;
        let q = get(&c.q, l);
        let dq = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
        let dist2 = dot(dq, dq);
        let dist_q = dist2.sqrt();
        let wi_q = [dq[0] / dist_q, dq[1] / dist_q, dq[2] / dist_q];
        let cos_light = -dot(get(&c.nq, l), wi_q);
        let wi_sphere = square_to_uniform_sphere_select(q[0], q[1]);
        let wi = select3(infinite, select3(env, q, wi_sphere), wi_q);
        let dist = if infinite { f32::INFINITY } else { dist_q };
        let pdf_l = if infinite {
            if env {
                c.l_area[l]
            } else {
                uniform_sphere_pdf()
            }
        } else if point {
            1.0
        } else {
            dist2 / (cos_light * c.l_area[l])
        };

        let wi_z = dot(wi, n);
        let wi_bz = if mirrored { -wi_z } else { wi_z };
        let both = front && wi_bz > 0.0;
        let k = FRAC_1_PI * wi_bz;
        let f = select3(both, scale3(reflectance, k), [0.0; 3]);
        let bsdf_pdf = if both && wi_bz > 0.0 {
            wi_bz * FRAC_1_PI
        } else {
            0.0
        };
        // A mirror (`BsdfFlags::has_smooth` false) connects to no light.
        let connects = shading
            && !mirror
            && c.has_light[l] != 0
            && (infinite || (dist != 0.0 && (point || !(cos_light <= 0.0))))
            && max_element(f) > 0.0
            && pdf_l > 0.0;
        let origin = offset_origin(p, ng, wi);
        let target = [
            p[0] + wi[0] * dist - origin[0],
            p[1] + wi[1] * dist - origin[1],
            p[2] + wi[2] * dist - origin[2],
        ];
        let len = dot(target, target).sqrt();
        let finite = dist.is_finite();
        let degenerate = len.is_nan() || len <= 0.0;
        let s_dir = select3(
            !finite || degenerate,
            wi,
            [target[0] / len, target[1] / len, target[2] / len],
        );
        let s_tmax = if !finite {
            f32::INFINITY
        } else if degenerate {
            0.0
        } else {
            len * (1.0 - 2e-4)
        };
        let light_pdf = pdf_l * light_select_pdf;
        // Lights at infinity without MIS count their samples alone.
        let w = if point || (infinite && !infinite_mis) {
            1.0
        } else {
            power_heuristic_select(light_pdf, bsdf_pdf)
        };
        let contribution = scale3(
            mul3(mul3(throughput, f), get(&c.l_radiance, l)),
            w / light_pdf,
        );
        c.shadow[l] = (connects) as u32;
        set(&mut c.s_origin, l, origin);
        set(&mut c.s_dir, l, s_dir);
        c.s_tmax[l] = s_tmax;
        set(&mut c.s_contribution, l, contribution);

        // The BSDF sample (`Diffuse::sample`: its weight is the reflectance) and the path's
        // continuation.
        let h = square_to_cosine_hemisphere_select(c.u_dir[0][l], c.u_dir[1][l]);
        let mut sampled = front && h[2] > 0.0;
        let mut pdf = if h[2] > 0.0 { h[2] * FRAC_1_PI } else { 0.0 };
        let hz = if mirrored { -h[2] } else { h[2] };
        let mut weight = reflectance;
        let mut local = [h[0], h[1], hz];
        if MIRROR {
            // `Mirror::sample` on the side seen (`SidedBsdf::sample`): wi = reflect_z(wo), whose
            // z flipped twice on a mirrored back is wo's z again; the weight's cosine is the
            // side's; pdf infinite (a delta lobe: `scatter` keeps the cone's spread and the
            // specular chain).
            let (m_sampled, m_weight) = mirror_sample_select(reflectance, wo_bz);
            let wo_x = dot(wo, s);
            let wo_y = dot(wo, tt);
            sampled = if mirror { m_sampled } else { sampled };
            pdf = if mirror { f32::INFINITY } else { pdf };
            weight = select3(mirror, m_weight, weight);
            local = select3(mirror, [-wo_x, -wo_y, wo_z], local);
        }
        let weight_max = max_element(weight);
        let cont = shading && sampled && !(weight_max.is_nan() || weight_max <= 0.0);
        let new_throughput = mul3(throughput, weight);
        let dir = [
            s[0] * local[0] + tt[0] * local[1] + n[0] * local[2],
            s[1] * local[0] + tt[1] * local[1] + n[1] * local[2],
            s[2] * local[0] + tt[2] * local[1] + n[2] * local[2],
        ];
        let new_origin = offset_origin(p, ng, dir);
        let eta = c.eta[l];
        let rr_q = (max_element(new_throughput) * eta * eta).min(0.95);
        let roulette = c.roulette[l] != 0;
        let survives = !roulette || !(c.u_rr[l] >= rr_q);
        // A path that roulette ends keeps the undivided throughput, as the scalar code's.
        let kept = select3(
            roulette && survives,
            [
                new_throughput[0] / rr_q,
                new_throughput[1] / rr_q,
                new_throughput[2] / rr_q,
            ],
            new_throughput,
        );
        c.cont[l] = (cont) as u32;
        c.alive[l] = (cont && survives) as u32;
        set(&mut c.new_throughput, l, kept);
        c.new_pdf[l] = pdf;
        set(&mut c.new_origin, l, new_origin);
        set(&mut c.new_dir, l, dir);
    }
}

/// [`shade`] over sixteen lanes with AVX-512.
///
/// # Safety
/// The CPU must have AVX-512 F, BW and VL, AVX2 and FMA (`accel::Simd::Avx512`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
pub(super) unsafe fn shade_avx512<const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<16>,
    light_select_pdf: f32,
    infinite_mis: bool,
) {
    shade::<16, EXTRA, MIRROR>(c, light_select_pdf, infinite_mis)
}

/// [`shade`] over eight lanes with AVX2.
///
/// # Safety
/// The CPU must have AVX2 and FMA (`accel::Simd::Avx2` or better).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn shade_avx2<const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<8>,
    light_select_pdf: f32,
    infinite_mis: bool,
) {
    shade::<8, EXTRA, MIRROR>(c, light_select_pdf, infinite_mis)
}

/// [`shade`] over eight lanes with the baseline instruction set (SSE2 on x86-64: two vectors
/// of four).
#[inline(never)]
pub(super) fn shade_portable<const EXTRA: bool, const MIRROR: bool>(
    c: &mut Chunk<8>,
    light_select_pdf: f32,
    infinite_mis: bool,
) {
    shade::<8, EXTRA, MIRROR>(c, light_select_pdf, infinite_mis)
}
