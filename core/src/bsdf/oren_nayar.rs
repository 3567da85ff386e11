//! Rough diffuse reflection: MaterialX's `oren_nayar_diffuse_bsdf` (MaterialX 1.39), the diffuse
//! lobe of Autodesk Standard Surface (`diffuse_roughness`) and OpenPBR (`base_diffuse_roughness`).
//!
//! With μi, μo the cosines to the normal, s = ωi·ωo − μi μo (the cosine of the azimuth
//! difference times sinθi sinθo) and r ∈ [0, 1] the roughness, three variants are offered
//! ([`OrenNayarModel`]):
//!
//! * **Qualitative** (Oren & Nayar 1994, their qualitative model, in MaterialX's reading): σ = r,
//!   A = 1 − 0.5 σ²/(σ² + 0.33), B = 0.45 σ²/(σ² + 0.09) and
//!   f = ρ/π (A + B max(0, s)/max(μi, μo)). This is what MaterialX evaluates when
//!   `energy_compensation` is false, its default, hence what Standard Surface uses. Its
//!   directional albedo (closed form below) exceeds 1 near grazing for small roughness, by at
//!   most 1.52% (σ ≈ 0.2, μ → 0), so a white surface reflects slightly more than it receives at
//!   grazing views.
//! * **Fujii** (Fujii's improved qualitative model, "FON"): A = 1/(1 + c₁ r), B = r A with
//!   c₁ = 1/2 − 2/(3π), and f = ρ/π (A + B s/t) with t = max(μi, μo) where s > 0 and t = 1
//!   elsewhere. Its albedo never exceeds 1 (it equals 1 at grazing and decreases).
//! * **EnergyPreserving** (EON: Portsmouth, Kutz & Hill 2024, "EON: a practical
//!   energy-preserving rough diffuse BRDF", as adopted by OpenPBR): the Fujii lobe plus a
//!   multiple-scattering lobe of the Kulla–Conty form
//!   f_ms = ρ_ms/π (1 − E(μo))(1 − E(μi))/(1 − Ē), ρ_ms = ρ² Ē/(1 − ρ(1 − Ē)),
//!   where E is the Fujii lobe's white directional albedo and Ē its hemispherical average.
//!   MaterialX evaluates this when `energy_compensation` is true, which OpenPBR sets. A white
//!   surface then reflects exactly everything at every angle.
//!
//! The roughness is used as given (not squared) by all three, as in MaterialX. The Fujii
//! albedo has the closed form E(μ) = A (1 + r G(μ)/π) with
//! G(μ) = sinθ (θ − sinθ cosθ) + (2/3)(sinθ/cosθ)(1 − sin³θ) − (2/3) sinθ, θ = acos μ, and
//! Ē = A (1 + c₂ r), c₂ = 2/3 − 28/(15π) (these are the expressions MaterialX evaluates, and
//! they are exact integrals of the lobe, so the compensation is exact rather than fitted). For
//! the qualitative model the same integration gives E(μ) = A + (B/π)(G(μ) + (2/3) sinθ) and
//! Ē = A + B (c₂ + 4/(9π)); MaterialX's shader instead fits that albedo with a rational
//! polynomial, which deviates from the closed form by up to 0.023 (at μ = 1, σ = 1), so the
//! closed form is used here.
//!
//! MaterialX's GLSL shader clamps ωi·ωo to [ε, 1] before evaluating the lobe, which changes s
//! where ωi·ωo < 0 (s becomes ε − μi μo instead of the more negative true value). That is inert
//! for the qualitative model (s ≤ 0 contributes nothing) but brightens the Fujii and EON lobes
//! in forward-scattering configurations, so that the shader's white EON reflects more than it
//! receives (1.14 at r = 1, μo = 0.1; 1.03 at r = 0.5, μo = 0.5, by quadrature). The lobes here
//! use the true s, as in the EON paper, for which the closed forms above are exact.
//!
//! Sampling is cosine-weighted (pdf μi/π), exact for every variant; the lobes are within a small
//! factor of Lambertian except at grazing retro-reflection.

use super::{flags, BsdfSample};
use crate::math::{sample_cosine_hemisphere, INV_PI, PI};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// c₁ = 1/2 − 2/(3π): G(0)/π, the value that makes the Fujii albedo 1 at grazing.
const FON_C1: f32 = 0.5 - 2.0 / (3.0 * PI);
/// c₂ = 2/3 − 28/(15π) = 2∫G(μ)μ dμ / π.
const FON_C2: f32 = 2.0 / 3.0 - 28.0 / (15.0 * PI);

/// Variant of the Oren–Nayar lobe (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrenNayarModel {
    /// Oren & Nayar's qualitative model (MaterialX `energy_compensation = false`, Standard
    /// Surface).
    Qualitative,
    /// Fujii's improved qualitative model, single scattering only.
    Fujii,
    /// EON: Fujii plus its exact multiple-scattering compensation (MaterialX
    /// `energy_compensation = true`, OpenPBR).
    EnergyPreserving,
}

/// The function G(μ) of the Fujii albedo, written without the cancellation of the textbook form
/// at grazing angles: (sinθ/cosθ)(1 − sin³θ) = sinθ cosθ (1 + sinθ + sin²θ)/(1 + sinθ).
#[inline]
fn fujii_g(mu: f32) -> f32 {
    let mu = mu.clamp(0.0, 1.0);
    let si = (1.0 - mu * mu).max(0.0).sqrt();
    si * (mu.acos() - si * mu) + (2.0 / 3.0) * si * (mu * (1.0 + si + si * si) / (1.0 + si) - 1.0)
}

/// White directional albedo of the Fujii lobe at μ = cosθo and roughness r ∈ [0, 1]:
/// A (1 + r G(μ)/π), A = 1/(1 + c₁ r).
pub fn fujii_albedo(mu: f32, roughness: f32) -> f32 {
    let r = clamp_roughness(roughness);
    (1.0 + r * fujii_g(mu) * INV_PI) / (1.0 + FON_C1 * r)
}

/// White directional albedo of the qualitative model at μ = cosθo and roughness σ ∈ [0, 1]:
/// A + (B/π)(G(μ) + (2/3) sinθ). Exceeds 1 by up to 0.0152 near grazing.
pub fn qualitative_albedo(mu: f32, roughness: f32) -> f32 {
    let (a, b) = qualitative_ab(clamp_roughness(roughness));
    let si = (1.0 - mu.clamp(0.0, 1.0).powi(2)).max(0.0).sqrt();
    a + b * INV_PI * (fujii_g(mu) + (2.0 / 3.0) * si)
}

#[inline]
fn clamp_roughness(r: f32) -> f32 {
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// (A, B) of the qualitative model for σ.
#[inline]
fn qualitative_ab(sigma: f32) -> (f32, f32) {
    let s2 = sigma * sigma;
    (1.0 - 0.5 * s2 / (s2 + 0.33), 0.45 * s2 / (s2 + 0.09))
}

/// Oren–Nayar diffuse reflection, written for ωo in the upper hemisphere (zero below).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrenNayar {
    color: SampledSpectrum,
    model: OrenNayarModel,
    r: f32,
    /// Qualitative: A and B. Fujii and EON: A = 1/(1 + c₁ r) and B = r A.
    a: f32,
    b: f32,
    /// EON: ρ_ms/π · A r / (c₁ − c₂), so that f_ms = ms · (c₁ − G(μo)/π)(c₁ − G(μi)/π)
    /// (1 − E(μ) = A r (c₁ − G(μ)/π) and 1 − Ē = A r (c₁ − c₂): no small differences).
    ms: SampledSpectrum,
    /// EON: ρ_ms.
    rho_ms: SampledSpectrum,
}

impl OrenNayar {
    /// Lobe of reflectance `color` (each component in [0, 1]) and roughness in [0, 1] (clamped;
    /// non-finite reads 0; 0 is Lambertian for every model).
    pub fn new(color: SampledSpectrum, roughness: f32, model: OrenNayarModel) -> OrenNayar {
        let r = clamp_roughness(roughness);
        let (a, b) = match model {
            OrenNayarModel::Qualitative => qualitative_ab(r),
            OrenNayarModel::Fujii | OrenNayarModel::EnergyPreserving => {
                let a = 1.0 / (1.0 + FON_C1 * r);
                (a, r * a)
            }
        };
        let (mut ms, mut rho_ms) = (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        if model == OrenNayarModel::EnergyPreserving && r > 0.0 {
            let e_avg = a * (1.0 + FON_C2 * r);
            rho_ms = SampledSpectrum::from_fn(|i| {
                let rho = color[i];
                rho * rho * e_avg / (1.0 - rho * (1.0 - e_avg))
            });
            ms = rho_ms * (INV_PI * a * r / (FON_C1 - FON_C2));
        }
        OrenNayar { color, model, r, a, b, ms, rho_ms }
    }

    /// The variant.
    #[inline]
    pub fn model(&self) -> OrenNayarModel {
        self.model
    }

    /// BSDF value (cosine excluded).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let s = wi.dot(wo) - wi.z * wo.z;
        let s_over_t = if s > 0.0 {
            s / wi.z.max(wo.z)
        } else if self.model == OrenNayarModel::Qualitative {
            0.0
        } else {
            s
        };
        let single = self.color * (INV_PI * (self.a + self.b * s_over_t));
        if self.model != OrenNayarModel::EnergyPreserving {
            return single;
        }
        let lo = (FON_C1 - fujii_g(wo.z) * INV_PI).max(0.0);
        let li = (FON_C1 - fujii_g(wi.z) * INV_PI).max(0.0);
        single + self.ms * (lo * li)
    }

    /// Cosine-weighted density μi/π.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        super::lobes::cosine_pdf(wo, wi)
    }

    /// Samples ωi from the cosine-weighted hemisphere.
    pub fn sample_f(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let wi = sample_cosine_hemisphere(u);
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample { f: self.f(wo, wi), wi, pdf, flags: flags::DIFFUSE_REFLECTION, eta: 1.0 })
    }

    /// White directional albedo of the single-scattering lobe (the qualitative or the Fujii
    /// closed form).
    #[inline]
    fn e_single(&self, mu: f32) -> f32 {
        match self.model {
            OrenNayarModel::Qualitative => qualitative_albedo(mu, self.r),
            OrenNayarModel::Fujii | OrenNayarModel::EnergyPreserving => fujii_albedo(mu, self.r),
        }
    }

    /// Directional albedo ∫ f cosθi dωi at μ = cosθo (closed form; for EON
    /// ρ E(μ) + ρ_ms (1 − E(μ))).
    pub fn albedo(&self, mu: f32) -> SampledSpectrum {
        let e = self.e_single(mu);
        match self.model {
            OrenNayarModel::EnergyPreserving => self.color * e + self.rho_ms * (1.0 - e),
            _ => self.color * e,
        }
    }

    /// Hemispherical average 2∫albedo(μ) μ dμ (closed form).
    pub fn albedo_avg(&self) -> SampledSpectrum {
        match self.model {
            OrenNayarModel::Qualitative => self.color * (self.a + self.b * (FON_C2 + 4.0 / (9.0 * PI))),
            OrenNayarModel::Fujii => self.color * (self.a * (1.0 + FON_C2 * self.r)),
            OrenNayarModel::EnergyPreserving => {
                let e = self.a * (1.0 + FON_C2 * self.r);
                self.color * e + self.rho_ms * (1.0 - e)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::thin_film::gauss_legendre;
    use super::*;
    use crate::testing::{dir_mu, random_upper};
    use crate::testing::chi2::{chi2_sphere, Chi2Config, TestRng};

    const MODELS: [OrenNayarModel; 3] =
        [OrenNayarModel::Qualitative, OrenNayarModel::Fujii, OrenNayarModel::EnergyPreserving];


    /// ∫ f cosθi dωi for ωo at μ, by product Gauss–Legendre in (θi, φi) cut where the lobe has
    /// kinks (θi = θo, where max(μi, μo) switches; φ = π/2, where s changes sign), so that each
    /// piece is smooth and the quadrature converges to rounding level. φ ∈ [0, π] by symmetry.
    fn quadrature_albedo(lobe: &OrenNayar, mu: f32) -> [f64; 4] {
        let wo = dir_mu(mu, 0.0);
        let theta_o = (mu as f64).acos();
        let gl = gauss_legendre(32);
        let theta_cuts = [0.0, theta_o, std::f64::consts::FRAC_PI_2];
        let phi_cuts = [0.0, std::f64::consts::FRAC_PI_2, std::f64::consts::PI];
        let mut acc = [0.0f64; 4];
        for t in theta_cuts.windows(2) {
            if t[1] <= t[0] {
                continue;
            }
            for &(x, wx) in &gl {
                let th = t[0] + (t[1] - t[0]) * x;
                for p in phi_cuts.windows(2) {
                    for &(y, wy) in &gl {
                        let ph = p[0] + (p[1] - p[0]) * y;
                        let wi = Vec3::new((th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, th.cos() as f32);
                        let f = lobe.f(wo, wi);
                        let w = wx * (t[1] - t[0]) * wy * (p[1] - p[0]) * 2.0 * th.cos() * th.sin();
                        for i in 0..4 {
                            acc[i] += w * f[i] as f64;
                        }
                    }
                }
            }
        }
        acc
    }

    fn colour() -> SampledSpectrum {
        SampledSpectrum([0.9, 0.5, 0.2, 1.0])
    }

    #[test]
    fn zero_roughness_is_exactly_lambert() {
        let c = colour();
        let lambert = c * INV_PI;
        let mut rng = TestRng::new(1);
        for model in MODELS {
            let on = OrenNayar::new(c, 0.0, model);
            for _ in 0..500 {
                let (wo, wi) = (random_upper(&mut rng), random_upper(&mut rng));
                assert_eq!(on.f(wo, wi), lambert, "{model:?}");
            }
            assert_eq!(on.albedo(0.3), c, "{model:?}");
            assert_eq!(on.albedo(1.0), c, "{model:?}");
        }
    }

    #[test]
    fn zero_below_the_horizon() {
        for model in MODELS {
            let on = OrenNayar::new(colour(), 0.7, model);
            let (up, down) = (dir_mu(0.5, 0.3), dir_mu(-0.5, 1.0));
            assert_eq!(on.f(up, down), SampledSpectrum::ZERO);
            assert_eq!(on.f(down, up), SampledSpectrum::ZERO);
            assert_eq!(on.pdf(up, down), 0.0);
            assert_eq!(on.pdf(down, up), 0.0);
        }
    }

    #[test]
    fn reciprocity() {
        let mut rng = TestRng::new(2);
        for model in MODELS {
            for r in [0.3f32, 0.7, 1.0] {
                let on = OrenNayar::new(colour(), r, model);
                for _ in 0..2000 {
                    let (wo, wi) = (random_upper(&mut rng), random_upper(&mut rng));
                    let (a, b) = (on.f(wo, wi), on.f(wi, wo));
                    for i in 0..4 {
                        // the same symmetric expression with its arguments swapped: rounding
                        assert!((a[i] - b[i]).abs() <= 1e-6 * a[i].abs().max(1.0), "{model:?} r {r}: {a:?} vs {b:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn chi2_of_sampling() {
        // 3 models × 2 roughnesses × 3 directions; 1% family-wise, Šidák-corrected
        let n_tests = 18;
        for model in MODELS {
            for r in [0.5f32, 1.0] {
                let on = OrenNayar::new(colour(), r, model);
                for wo in [dir_mu(1.0, 0.0), dir_mu(0.5, 1.0), dir_mu(0.05, 2.0)] {
                    let res = chi2_sphere(
                        Chi2Config { samples: 50_000, ..Chi2Config::default() },
                        |rng| on.sample_f(wo, Vec2::new(rng.next_f32(), rng.next_f32())).map(|s| s.wi),
                        |wi| on.pdf(wo, wi),
                    );
                    assert!(res.passed(0.01, n_tests), "{model:?} r {r} wo {wo:?}: {res:?}");
                    // the sampler never fails: ∫pdf = 1 up to the cell quadrature (24² points)
                    assert!((res.pdf_integral - 1.0).abs() < 1e-3 && res.success_rate == 1.0, "{res:?}");
                    // samples return exactly f and pdf
                    let mut rng = TestRng::new(3);
                    for _ in 0..200 {
                        let s = on.sample_f(wo, Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
                        assert_eq!(s.f, on.f(wo, s.wi));
                        assert_eq!(s.pdf, on.pdf(wo, s.wi));
                        assert_eq!(s.flags, flags::DIFFUSE_REFLECTION);
                    }
                }
            }
        }
    }

    /// The closed-form albedos against quadrature of f·cos. The quadrature is converged to
    /// about 10⁻⁷ (doubling its order changes nothing at that level); f and the closed forms
    /// are single precision, so 2·10⁻⁶ is about 10 ulps at 1.
    #[test]
    fn closed_form_albedo_matches_quadrature() {
        for model in MODELS {
            for r in [0.1f32, 0.35, 0.6, 1.0] {
                let on = OrenNayar::new(colour(), r, model);
                for mu in [0.02f32, 0.15, 0.4, 0.7, 0.95, 1.0] {
                    let q = quadrature_albedo(&on, mu);
                    let e = on.albedo(mu);
                    for i in 0..4 {
                        assert!((q[i] - e[i] as f64).abs() < 2e-6, "{model:?} r {r} μ {mu}: quadrature {} vs {}", q[i], e[i]);
                    }
                }
            }
        }
    }

    /// The closed-form hemispherical averages against 64-point Gauss–Legendre of the closed-form
    /// albedo (whose only non-smooth point, the square-root behaviour of sinθ at μ = 1, limits
    /// the rule to ~10⁻⁶ here).
    #[test]
    fn closed_form_average_matches_quadrature() {
        let gl = gauss_legendre(64);
        for model in MODELS {
            for r in [0.1f32, 0.5, 1.0] {
                let on = OrenNayar::new(colour(), r, model);
                let avg = on.albedo_avg();
                let mut q = [0.0f64; 4];
                for &(x, w) in &gl {
                    let e = on.albedo(x as f32);
                    for i in 0..4 {
                        q[i] += 2.0 * w * x * e[i] as f64;
                    }
                }
                for i in 0..4 {
                    assert!((q[i] - avg[i] as f64).abs() < 1e-5, "{model:?} r {r}: {} vs {}", q[i], avg[i]);
                }
            }
        }
    }

    /// EON with a white albedo reflects everything at every angle. The compensation uses the
    /// exact albedo of the Fujii lobe (closed form, as MaterialX does), so the only error is
    /// single-precision rounding plus the quadrature's (about 10⁻⁷): 2·10⁻⁶ is asserted. (With
    /// the polynomial fit of E that Portsmouth, Kutz & Hill also give, the loss would be that
    /// fit's error instead.)
    #[test]
    fn eon_white_furnace_by_quadrature() {
        for r in [0.05f32, 0.2, 0.5, 0.8, 1.0] {
            let on = OrenNayar::new(SampledSpectrum::ONE, r, OrenNayarModel::EnergyPreserving);
            for mu in [0.001f32, 0.05, 0.2, 0.5, 0.8, 1.0] {
                let q = quadrature_albedo(&on, mu);
                assert!((q[0] - 1.0).abs() < 2e-6, "r {r} μ {mu}: {}", q[0]);
                assert!((on.albedo(mu)[0] - 1.0).abs() < 1e-6);
            }
            assert!((on.albedo_avg()[0] - 1.0).abs() < 1e-6);
        }
    }

    /// The same through the sampler (what an integrator sees): the mean of f cosθ / pdf over
    /// 20 000 samples is 1 within 4 standard errors.
    #[test]
    fn eon_white_furnace_by_sampling() {
        for r in [0.3f32, 1.0] {
            let on = OrenNayar::new(SampledSpectrum::ONE, r, OrenNayarModel::EnergyPreserving);
            for mu in [0.05f32, 0.5, 1.0] {
                let wo = dir_mu(mu, 0.4);
                let mut rng = TestRng::new(7);
                let n = 20_000;
                let (mut s1, mut s2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let s = on.sample_f(wo, Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
                    let w = (s.f[0] * s.wi.z / s.pdf) as f64;
                    s1 += w;
                    s2 += w * w;
                }
                let m = s1 / n as f64;
                let se = ((s2 / n as f64 - m * m) / n as f64).sqrt();
                assert!((m - 1.0).abs() < 4.0 * se + 1e-6, "r {r} μ {mu}: {m} ± {se}");
            }
        }
    }

    /// The Fujii lobe never reflects more than it receives; the qualitative one exceeds 1 near
    /// grazing by at most 0.01518 (the maximum over σ of −σ²/(2(σ²+0.33)) + 0.225σ²/(σ²+0.09),
    /// reached at σ ≈ 0.1985 and μ → 0, where G/π + (2/3)/π·sinθ → 1/2).
    #[test]
    fn plain_albedo_bounds() {
        let mut max_q = 0.0f32;
        for j in 0..=100 {
            let r = j as f32 / 100.0;
            for i in 0..=200 {
                let mu = i as f32 / 200.0;
                let e = fujii_albedo(mu, r);
                assert!(e <= 1.0 + 1e-6 && e > 0.5, "Fujii r {r} μ {mu}: {e}");
                max_q = max_q.max(qualitative_albedo(mu, r));
            }
            // the Fujii albedo is exactly 1 at grazing
            assert!((fujii_albedo(0.0, r) - 1.0).abs() < 1e-6);
        }
        assert!(max_q <= 1.01518 + 2e-6 && max_q > 1.015, "qualitative max albedo {max_q}");
    }

    /// The stable form of G agrees with the textbook expression where the latter is accurate.
    #[test]
    fn g_matches_textbook_form() {
        for i in 1..=100 {
            let mu = i as f64 / 100.0;
            let si = (1.0 - mu * mu).sqrt();
            let g = si * (mu.acos() - si * mu) + (2.0 / 3.0) * ((si / mu) * (1.0 - si * si * si) - si);
            assert!((fujii_g(mu as f32) as f64 - g).abs() < 2e-6, "μ {mu}");
        }
        assert!((fujii_g(0.0) as f64 - (std::f64::consts::FRAC_PI_2 - 2.0 / 3.0)).abs() < 1e-6);
        assert_eq!(fujii_g(1.0), 0.0);
    }
}
