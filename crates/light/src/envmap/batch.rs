//! [`EnvMap::eval_pdf_batch`]: the radiance and density of many escaped rays, their directions
//! turned into uv in SIMD lanes.

use super::{prefetch, EnvMap};
use glam::{Vec2, Vec3};

impl EnvMap {
    /// [`Self::eval_pdf`] of many escaped rays at once, bit for bit: `out[k]` is
    /// `self.eval_pdf(dirs[k], spreads[k])`, except that where `want_pdf[k]` is false (a path
    /// that needs no MIS weight) the density may be skipped and read 0: it costs a second
    /// lookup when the ray cone selects a coarser level. The directions are turned into uv and
    /// sin(theta) [`BATCH_LANES`] at a time in SIMD lanes (`simd` picks the instruction set the
    /// CPU was found to have), each lane's texel records are prefetched a chunk ahead, then the
    /// texels are read lane by lane. `out` is cleared first.
    pub fn eval_pdf_batch(
        &self,
        dirs: &[Vec3],
        spreads: &[f32],
        want_pdf: &[bool],
        simd: BatchSimd,
        out: &mut Vec<(Vec3, f32)>,
    ) {
        out.clear();
        if self.scale == 0.0 {
            out.resize(dirs.len(), (Vec3::ZERO, 0.0));
            return;
        }
        // The uv of the next chunk is found, and its texels hinted, before this chunk's are
        // read: the hints get a chunk's work to arrive.
        let chunks = dirs.len().div_ceil(BATCH_LANES);
        let chunk = |c: usize| c * BATCH_LANES..((c + 1) * BATCH_LANES).min(dirs.len());
        let mut next = self.hinted_uv_lanes(&dirs[chunk(0)], simd);
        for c in 0..chunks {
            let lanes = next;
            if c + 1 < chunks {
                next = self.hinted_uv_lanes(&dirs[chunk(c + 1)], simd);
            } else {
                next = UvLanes::default();
            }
            let range = chunk(c);
            for (k, (&spread, &want_pdf)) in spreads[range.clone()]
                .iter()
                .zip(&want_pdf[range])
                .enumerate()
            {
                let uv = Vec2::new(lanes.x[k], lanes.y[k]);
                out.push(self.eval_pdf_uv(uv, lanes.z[k], spread, want_pdf));
            }
        }
    }

    /// The uv and sin(theta) of up to [`BATCH_LANES`] world directions (`eval_pdf_batch`), in
    /// SIMD lanes, with the texel records their finest-level lookups read hinted.
    #[inline]
    fn hinted_uv_lanes(&self, dirs: &[Vec3], simd: BatchSimd) -> UvLanes {
        let mut lanes = UvLanes::default();
        for (k, d) in dirs.iter().enumerate() {
            let local = self.to_local * *d;
            (lanes.x[k], lanes.y[k], lanes.z[k]) = (local.x, local.y, local.z);
        }
        lanes.convert_to_uv_sin(simd);
        for k in 0..dirs.len() {
            // A hint only: the four texel records of the bilinear lookup, top-left at column
            // floor(u W - 1/2) and row floor(v (H - 1)) (the row remap of
            // `bilinear_finest_with_density`); the saturating casts and the clamps keep the
            // address inside the table except at the seam and the nadir, where a neighbour
            // is hinted instead (nothing is read).
            let column = ((lanes.x[k] * self.size.x - 0.5) as u32).min(self.width as u32 - 1);
            let row = ((lanes.y[k] * (self.size.y - 1.0)) as u32).min(self.height as u32 - 2);
            let top = self
                .texels
                .as_ptr()
                .wrapping_add(row as usize * self.width + column as usize);
            let bottom = top.wrapping_add(self.width);
            prefetch(top);
            prefetch(top.wrapping_add(1));
            prefetch(bottom);
            prefetch(bottom.wrapping_add(1));
        }
        lanes
    }
}

/// Directions per SIMD step of [`EnvMap::eval_pdf_batch`] (one AVX-512 register, two AVX2 ones).
pub const BATCH_LANES: usize = 16;

/// The instruction set [`EnvMap::eval_pdf_batch`] runs its lanes with; the caller detects it
/// (the renderer's `Simd`, which `TORREY_SIMD` caps). Every level gives the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchSimd {
    /// Baseline x86-64 (SSE2), or any other architecture.
    Portable,
    /// AVX2 and FMA (FMA is never used for these sums: the results stay those of `eval_pdf`).
    Avx2,
    /// AVX-512 F.
    Avx512,
}

/// [`BATCH_LANES`] local directions in structure-of-arrays form, turned in place into
/// (u, v, sin theta).
#[derive(Default)]
struct UvLanes {
    x: [f32; BATCH_LANES],
    y: [f32; BATCH_LANES],
    z: [f32; BATCH_LANES],
}

impl UvLanes {
    /// `EnvMap::local_dir_to_uv_sin` on every lane (unused lanes hold zero directions, which
    /// read as the zenith and are ignored).
    #[inline(always)]
    fn uv_sin_body(&mut self) {
        for k in 0..BATCH_LANES {
            let (uv, sin_theta) =
                EnvMap::local_dir_to_uv_sin_inline(Vec3::new(self.x[k], self.y[k], self.z[k]));
            (self.x[k], self.y[k], self.z[k]) = (uv.x, uv.y, sin_theta);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn uv_sin_avx2(&mut self) {
        self.uv_sin_body()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    fn uv_sin_avx512(&mut self) {
        self.uv_sin_body()
    }

    fn uv_sin_portable(&mut self) {
        self.uv_sin_body()
    }

    #[inline]
    fn convert_to_uv_sin(&mut self, simd: BatchSimd) {
        match simd {
            #[cfg(target_arch = "x86_64")]
            BatchSimd::Avx512 if is_x86_feature_detected!("avx512f") => {
                // SAFETY: the CPU has AVX-512 F (checked).
                unsafe { self.uv_sin_avx512() }
            }
            #[cfg(target_arch = "x86_64")]
            BatchSimd::Avx2 | BatchSimd::Avx512
                if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") =>
            {
                // SAFETY: the CPU has AVX2 and FMA (checked).
                unsafe { self.uv_sin_avx2() }
            }
            _ => self.uv_sin_portable(),
        }
    }
}
