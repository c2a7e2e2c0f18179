//! Test helpers: a small deterministic RNG and a chi-square goodness-of-fit test.

use glam::Vec2;

/// SplitMix64: tiny, deterministic, good enough for statistical tests.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
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

    pub fn vec2(&mut self) -> Vec2 {
        Vec2::new(self.f32(), self.f32())
    }
}

/// Chi-square test of observed counts against expected counts (same total scale). Cells with
/// expected count below 5 are pooled (as Mitsuba's test does). Observations in cells of zero
/// expectation fail immediately. Uses the Wilson-Hilferty normal approximation of the chi-square
/// distribution and rejects at significance 0.001 (z > 3.09). Returns (statistic, dof, z).
pub fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize, f64) {
    assert_eq!(observed.len(), expected.len());
    let mut stat = 0.0;
    let mut cells = 0usize;
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e <= 0.0 {
            assert!(o == 0.0, "{o} samples fell in a cell of zero expectation");
            continue;
        }
        if e < 5.0 {
            pool_o += o;
            pool_e += e;
            continue;
        }
        stat += (o - e) * (o - e) / e;
        cells += 1;
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        cells += 1;
    }
    assert!(cells >= 2, "too few cells for a chi-square test");
    let k = (cells - 1) as f64;
    let z = ((stat / k).powf(1.0 / 3.0) - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    (stat, cells - 1, z)
}

/// Asserts that the chi-square test passes at p > 0.001.
pub fn assert_chi_square(name: &str, observed: &[f64], expected: &[f64]) {
    let total_o: f64 = observed.iter().sum();
    let total_e: f64 = expected.iter().sum();
    assert!(
        (total_o - total_e).abs() <= 1e-2 * total_e.max(1.0),
        "{name}: expected counts sum to {total_e}, observed {total_o}"
    );
    let (stat, dof, z) = chi_square(observed, expected);
    assert!(
        z < 3.09,
        "{name}: chi-square {stat:.1} with {dof} dof (z = {z:.2}) rejects at p=0.001"
    );
}

/// Sanity check of the test itself: a clearly wrong distribution must be rejected.
#[test]
fn chi_square_rejects_wrong_distribution() {
    let observed = [1200.0, 800.0, 1000.0, 1000.0];
    let expected = [1000.0; 4];
    let (_, _, z) = chi_square(&observed, &expected);
    assert!(z > 3.09);
    let observed = [1010.0, 990.0, 1020.0, 980.0];
    let (_, _, z) = chi_square(&observed, &expected);
    assert!(z < 3.09);
}
