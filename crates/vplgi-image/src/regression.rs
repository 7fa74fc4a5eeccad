//! Statistical comparison of a render with a stored reference (`vplgi reference`: the mean and
//! per-pixel sample variance of n independent renders).
//!
//! A new independent render x of the same configuration differs from the reference mean m by a
//! residual whose variance is σ²(1 + 1/n); with the sample variance s² in place of σ², the
//! statistic t = (x − m) / (s √(1 + 1/n)) follows Student's t with n − 1 degrees of freedom.
//! Every pixel and channel is tested, two-sided, at level α divided by the number of tests
//! (Bonferroni: valid however the pixels are correlated, and in a VPL render they are, through
//! the shared VPLs). Where the reference has no variance (misses, emitters seen directly), the
//! render must match to 1e-5 relative.
//!
//! The t-test assumes normal per-pixel noise, and VPL renders are heavy-tailed: a VPL or a direct
//! light sample close to a surface makes a bright outlier now and then. So a render of the very
//! configuration of the reference fails a handful of pixel tests (measured: 0.02-0.45 % on the
//! fixtures), and callers bound the failing fraction rather than demanding none.
//!
//! Regions are the second test, and the sound one under any correlation and tails of the
//! pixels. The mean over a block of pixels has a standard deviation of at most the mean of the
//! pixels' standard deviations (Cauchy-Schwarz, whatever their correlation), so
//! (x̄ − m̄) / (mean(s) √(1 + 1/n)) is a conservative t statistic. It is tested with n − 1
//! degrees of freedom, Bonferroni over blocks and channels. Averaging also tames the outliers, so
//! this catches a bias over an area (a wrong factor, a missing bounce) that single pixels are
//! too noisy to show.

use crate::Image;

/// The outcome of [`compare_with_reference`] or [`compare_regions`].
#[derive(Clone, Debug, PartialEq)]
pub struct Regression {
    /// Critical |t| for the corrected level.
    pub threshold: f64,
    /// Tests (pixels or blocks, x channels) beyond it, or off where the reference has no variance.
    pub failures: usize,
    /// The largest |t| and where (pixel or block index, channel).
    pub worst: (f64, usize, usize),
    pub tests: usize,
}

impl Regression {
    pub fn passed(&self) -> bool {
        self.failures == 0
    }

    /// The fraction of tests that failed.
    pub fn failed_fraction(&self) -> f64 {
        self.failures as f64 / self.tests.max(1) as f64
    }
}

/// The conservative block test (module docs): `block` x `block` pixel blocks (the last ones
/// smaller), at family-wise level `alpha`.
pub fn compare_regions(
    mean: &Image,
    variance: &Image,
    seeds: u32,
    render: &Image,
    block: u32,
    alpha: f64,
) -> Regression {
    let (w, h) = (mean.width, mean.height);
    let (bx, by) = (w.div_ceil(block), h.div_ceil(block));
    let tests = (bx * by * 3) as usize;
    let dof = seeds.saturating_sub(1).max(1) as f64;
    let threshold = student_t_two_sided(alpha / tests as f64, dof);
    let scale = (1.0 + 1.0 / seeds.max(1) as f64).sqrt();
    let (mut failures, mut worst) = (0, (0.0f64, 0usize, 0usize));
    for j in 0..by {
        for i in 0..bx {
            for c in 0..3 {
                let (mut dm, mut sd, mut count) = (0.0f64, 0.0f64, 0.0f64);
                for y in j * block..((j + 1) * block).min(h) {
                    for x in i * block..((i + 1) * block).min(w) {
                        let k = (y * w + x) as usize;
                        dm += render.pixels[k][c] as f64 - mean.pixels[k][c] as f64;
                        sd += (variance.pixels[k][c] as f64).max(0.0).sqrt();
                        count += 1.0;
                    }
                }
                let (dm, sd) = (dm / count, sd / count);
                let t = if sd > 0.0 {
                    dm / (sd * scale)
                } else if dm.abs() <= 1e-6 {
                    0.0
                } else {
                    f64::INFINITY
                };
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(t.abs() <= threshold) {
                    failures += 1;
                }
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(t.abs() <= worst.0) {
                    worst = (t.abs(), (j * bx + i) as usize, c);
                }
            }
        }
    }
    Regression { threshold, failures, worst, tests }
}

/// Tests `render` against the reference (`mean`, `variance` of `seeds` renders) at family-wise
/// level `alpha`.
pub fn compare_with_reference(
    mean: &Image,
    variance: &Image,
    seeds: u32,
    render: &Image,
    alpha: f64,
) -> Regression {
    let tests = mean.pixels.len() * 3;
    let dof = seeds.saturating_sub(1).max(1) as f64;
    let threshold = student_t_two_sided(alpha / tests as f64, dof);
    let scale = (1.0 + 1.0 / seeds.max(1) as f64).sqrt();
    let mut failures = 0;
    let mut worst = (0.0f64, 0usize, 0usize);
    for (i, ((m, v), x)) in mean.pixels.iter().zip(&variance.pixels).zip(&render.pixels).enumerate()
    {
        for c in 0..3 {
            let (m, v, x) = (m[c] as f64, v[c] as f64, x[c] as f64);
            let t = if v > 0.0 {
                (x - m) / (v.sqrt() * scale)
            } else if (x - m).abs() <= 1e-5 * m.abs().max(1e-3) {
                0.0
            } else {
                f64::INFINITY
            };
            // Negated so that a NaN counts as a failure.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(t.abs() <= threshold) {
                failures += 1;
            }
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if !(t.abs() <= worst.0) {
                worst = (t.abs(), i, c);
            }
        }
    }
    Regression { threshold, failures, worst, tests }
}

/// The t with P(|T| > t) = p for Student's t with `dof` degrees of freedom (bisection on the
/// regularised incomplete beta function: P(|T| > t) = I_{dof/(dof+t²)}(dof/2, 1/2)).
pub fn student_t_two_sided(p: f64, dof: f64) -> f64 {
    let tail = |t: f64| incomplete_beta(dof / (dof + t * t), dof / 2.0, 0.5);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while tail(hi) > p && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9).
fn ln_gamma(x: f64) -> f64 {
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
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let s = C[0] + (1..9).map(|k| C[k] / (x + k as f64)).sum::<f64>();
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// The regularised incomplete beta function I_x(a, b), by its continued fraction (modified
/// Lentz), using the symmetry I_x(a, b) = 1 − I_{1−x}(b, a) where that converges faster.
fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x > (a + 1.0) / (a + b + 2.0) {
        return 1.0 - incomplete_beta(1.0 - x, b, a);
    }
    let tiny = 1e-300;
    let (mut c, mut d) = (1.0, 1.0 - (a + b) * x / (a + 1.0));
    d = 1.0 / if d.abs() < tiny { tiny } else { d };
    let mut f = d;
    for m in 1..500 {
        let m = m as f64;
        for numerator in [
            m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m)),
            -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0)),
        ] {
            d = 1.0 + numerator * d;
            d = 1.0 / if d.abs() < tiny { tiny } else { d };
            c = 1.0 + numerator / c;
            if c.abs() < tiny {
                c = tiny;
            }
            f *= c * d;
        }
        if (c * d - 1.0).abs() < 1e-15 {
            break;
        }
    }
    front * f / a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn student_t_quantiles_match_tables() {
        // Two-sided: P(|T| > t) = 0.05 with 7 dof is t = 2.3646; 0.01 with 15 dof, 2.9467;
        // 1e-6 with 1e6 dof approaches the normal's 4.8916.
        for (p, dof, t) in [
            (0.05, 7.0, 2.364_624),
            (0.01, 15.0, 2.946_713),
            (0.2, 1.0, 3.077_684),
            (1e-6, 1e6, 4.891_638),
        ] {
            let got = student_t_two_sided(p, dof);
            assert!((got - t).abs() < 1e-4 * t, "p {p}, dof {dof}: {got} vs {t}");
        }
    }

    fn image(v: f32) -> Image {
        Image { width: 8, height: 8, pixels: vec![[v; 3]; 64] }
    }

    #[test]
    fn the_test_accepts_noise_and_rejects_outliers_and_bias() {
        let (mean, var) = (image(1.0), image(0.01));
        // Within a few sigma everywhere: accepted.
        let mut ok = image(1.0);
        for (i, p) in ok.pixels.iter_mut().enumerate() {
            p[0] += 0.3 * ((i % 7) as f32 - 3.0) / 3.0;
        }
        let r = compare_with_reference(&mean, &var, 16, &ok, 0.01);
        assert!(r.passed(), "{r:?}");
        // One pixel 30 sigma off: rejected, and located.
        let mut outlier = image(1.0);
        outlier.pixels[37][1] = 4.0;
        let r = compare_with_reference(&mean, &var, 16, &outlier, 0.01);
        assert_eq!((r.failures, r.worst.1, r.worst.2), (1, 37, 1));
        // A 2x brightness everywhere: rejected everywhere.
        assert_eq!(compare_with_reference(&mean, &var, 16, &image(2.0), 0.01).failures, 192);
        // No variance: exact match required.
        let zero = image(0.0);
        assert!(compare_with_reference(&image(0.5), &zero, 16, &image(0.5), 0.01).passed());
        assert!(!compare_with_reference(&image(0.5), &zero, 16, &image(0.5001), 0.01).passed());
        // NaN never passes.
        assert!(!compare_with_reference(&mean, &var, 16, &image(f32::NAN), 0.01).passed());
        // Blocks: the noise above averages out; 60 % more light in one 4x4 block (6 standard
        // deviations of a pixel) does not.
        assert!(compare_regions(&mean, &var, 16, &ok, 4, 0.01).passed());
        let mut bias = image(1.0);
        for y in 4..8 {
            for x in 0..4 {
                bias.pixels[y * 8 + x] = [1.6; 3];
            }
        }
        let r = compare_regions(&mean, &var, 16, &bias, 4, 0.01);
        assert_eq!((r.failures, r.worst.1), (3, 2), "{r:?}");
    }
}
