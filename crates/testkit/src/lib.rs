//! Statistical helpers shared by the tests of torrey's crates (a dev-dependency only): a small
//! deterministic RNG and Pearson's chi-square goodness-of-fit test with an exact p-value, as pbrt
//! and Mitsuba test their sampling routines against their densities.

/// SplitMix64: deterministic, dependency-free, good enough for statistical tests.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 24 bits.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    pub fn vec2(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.f32(), self.f32())
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9), accurate to ~1e-15 for x > 0.
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let lg = ln_gamma(a);
    if x < a + 1.0 {
        // Series for P(a, x).
        let mut sum = 1.0 / a;
        let mut term = sum;
        let mut ap = a;
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - lg).exp()
    } else {
        // Continued fraction for Q(a, x) (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - lg).exp() * h
    }
}

/// P(X > x) for X chi-square distributed with `dof` degrees of freedom.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    gamma_q(0.5 * dof, 0.5 * x)
}

/// Pearson chi-square test of observed against expected counts. Cells with expected counts
/// below 5 are pooled (smallest first) as pbrt and Mitsuba do; an observation in a cell whose
/// expected count is (numerically) zero fails outright. Returns (p-value, statistic, dof).
pub fn chi2_test(observed: &[f64], expected: &[f64]) -> Result<(f64, f64, usize), String> {
    assert_eq!(observed.len(), expected.len());
    let mut cells: Vec<(f64, f64)> = observed
        .iter()
        .zip(expected)
        .map(|(&o, &e)| (e, o))
        .collect();
    cells.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    let (mut stat, mut n_cells) = (0.0, 0usize);
    for &(e, o) in &cells {
        if e < 1e-9 {
            if o > 0.0 {
                return Err(format!(
                    "{o} samples fell in a cell with expected count {e}"
                ));
            }
            continue;
        }
        if e < 5.0 || pool_e > 0.0 && pool_e < 5.0 {
            pool_e += e;
            pool_o += o;
            if pool_e >= 5.0 {
                stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                n_cells += 1;
                pool_e = 0.0;
                pool_o = 0.0;
            }
            continue;
        }
        stat += (o - e) * (o - e) / e;
        n_cells += 1;
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        n_cells += 1;
    }
    if n_cells < 2 {
        return Ok((1.0, stat, 0));
    }
    let dof = n_cells - 1;
    Ok((chi2_sf(stat, dof as f64), stat, dof))
}

/// Asserts that `observed` counts fit `expected` counts (which must sum to the same total, up to
/// 1%): the chi-square test must not reject at significance 0.001.
pub fn assert_chi_square(name: &str, observed: &[f64], expected: &[f64]) {
    let total_o: f64 = observed.iter().sum();
    let total_e: f64 = expected.iter().sum();
    assert!(
        (total_o - total_e).abs() <= 1e-2 * total_e.max(1.0),
        "{name}: expected counts sum to {total_e}, observed {total_o}"
    );
    match chi2_test(observed, expected) {
        Ok((p, stat, dof)) => assert!(
            p > 1e-3,
            "{name}: chi-square {stat:.1} with {dof} dof (p = {p:.2e}) rejects at p = 0.001"
        ),
        Err(e) => panic!("{name}: {e}"),
    }
}

/// The CRC-32 of PNG chunks (and zlib, gzip): tests that write image files by hand (a header
/// that lies about its size, a huge flat image streamed to the compressor) need valid checksums.
pub fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_sf_matches_tables() {
        // Critical values from standard chi-square tables.
        assert!((chi2_sf(3.841, 1.0) - 0.05).abs() < 1e-4);
        assert!((chi2_sf(18.307, 10.0) - 0.05).abs() < 1e-4);
        assert!((chi2_sf(124.342, 100.0) - 0.05).abs() < 1e-4);
        assert!((chi2_sf(6.635, 1.0) - 0.01).abs() < 1e-4);
        assert!((chi2_sf(2.0, 2.0) - (-1.0f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn chi2_test_detects_a_wrong_distribution() {
        let expected = vec![1000.0; 10];
        let mut observed = expected.clone();
        observed[0] += 150.0;
        observed[1] -= 150.0;
        let (p, _, dof) = chi2_test(&observed, &expected).unwrap();
        assert_eq!(dof, 9);
        assert!(p < 1e-3, "p = {p}");
        assert!(chi2_test(&[1.0, 10.0], &[0.0, 11.0]).is_err());
        // Small deviations pass.
        let observed = [1010.0, 990.0, 1020.0, 980.0];
        assert!(chi2_test(&observed, &[1000.0; 4]).unwrap().0 > 1e-3);
    }

    #[test]
    #[should_panic(expected = "rejects")]
    fn assert_chi_square_panics_on_a_wrong_distribution() {
        assert_chi_square("skewed", &[1200.0, 800.0, 1000.0, 1000.0], &[1000.0; 4]);
    }
}
