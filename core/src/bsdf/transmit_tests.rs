//! Tests of what transmits beside a plain dielectric: a dielectric over part of a preview
//! stack ([`super::super::blend`]), a dielectric's transmission tint, and a thin wall's
//! translucent and straight transmission ([`preview::ThinWalled`]): χ² of the samplers,
//! consistency, energy, and exact values where they exist.

use super::*;

fn clear(eta: f32, r: f32) -> Bsdf {
    Bsdf::dielectric(eta, r).unwrap()
}

fn blend(c: Bsdf, p: PreviewParams, t: f32) -> Bsdf {
    Bsdf::blend(c, Bsdf::preview(p).unwrap(), t).unwrap()
}

const TINT: SampledSpectrum = SampledSpectrum([0.9, 0.5, 0.2, 0.7]);

/// The configurations of the χ² and consistency tests (4 of them, 4 ωo each).
fn configs() -> Vec<(&'static str, Bsdf)> {
    let base = preview_params();
    vec![
        ("rough glass over a rough base", blend(clear(1.5, 0.4), base, 0.6)),
        ("smooth glass over a rough base", blend(clear(1.5, 0.0), PreviewParams { roughness: 0.3, ..base }, 0.5)),
        ("rough water over a mirror-coated base", blend(clear(1.333, 0.6), PreviewParams { roughness: 0.0, clearcoat: 1.0, clearcoat_roughness: 0.0, ..base }, 0.3)),
        ("tinted glass over a metal", blend(clear(1.5, 0.5).tint_transmission(TINT).unwrap(), PreviewParams { metallic: 0.6, ..base }, 0.7)),
    ]
}

#[test]
fn chi2_blend() {
    for (name, b) in configs() {
        for wo in [dir(10.0, 0.0), dir(70.0, 30.0), dir(135.0, 10.0), dir(100.0, 0.0)] {
            check_chi2_quad(name, &b, wo, TransportMode::Radiance, 64);
            check_consistency(name, &b, wo, TransportMode::Radiance);
            check_consistency(name, &b, wo, TransportMode::Importance);
        }
    }
}

/// The mixture's directional albedo is t × the dielectric's + (1 − t) × the stack's, each
/// estimated apart (the delta lobes of both parts, and their shared mirror direction, included).
#[test]
fn the_blend_reflects_and_transmits_its_parts_in_their_shares() {
    let base = preview_params();
    let cases = [
        (clear(1.5, 0.4), PreviewParams { roughness: 0.5, ..base }, 0.6),
        (clear(1.5, 0.0), PreviewParams { roughness: 0.0, ..base }, 0.4),
        (clear(1.333, 0.0).tint_transmission(TINT).unwrap(), PreviewParams { roughness: 0.2, clearcoat: 1.0, clearcoat_roughness: 0.0, ..base }, 0.8),
    ];
    for (i, (c, p, t)) in cases.into_iter().enumerate() {
        let b = blend(c, p, t);
        let o = Bsdf::preview(p).unwrap();
        for wo in [dir(20.0, 0.0), dir(75.0, 20.0), dir(160.0, 40.0)] {
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let (mb, sb) = furnace(&b, wo, mode, 40_000, true);
                let (mc, sc) = furnace(&c, wo, mode, 40_000, true);
                let (mo, so) = furnace(&o, wo, mode, 40_000, true);
                let want = t as f64 * mc + (1.0 - t as f64) * mo;
                let sigma = (sb * sb + (t as f64 * sc).powi(2) + ((1.0 - t as f64) * so).powi(2)).sqrt();
                assert!((mb - want).abs() < 4.0 * sigma + 1e-6, "case {i} wo {wo:?} {mode:?}: {mb} ± {sb} vs {want} ± {sigma}");
            }
        }
    }
}

/// A tint multiplies each transmitted sample's f by exactly the tint and leaves reflection,
/// directions and densities as they were, smooth or rough, from either side.
#[test]
fn a_tint_multiplies_transmission_only() {
    for r in [0.0f32, 0.3, 0.8] {
        let plain = clear(1.5, r);
        let tinted = plain.tint_transmission(TINT).unwrap();
        let mut rng = TestRng::new(77);
        let (mut seen_t, mut seen_r) = (false, false);
        for wo in [dir(30.0, 0.0), dir(150.0, 50.0)] {
            for _ in 0..2000 {
                let (uc, u) = rng_u(&mut rng);
                let (Some(a), Some(b)) = (plain.sample_f(wo, uc, u, TransportMode::Radiance), tinted.sample_f(wo, uc, u, TransportMode::Radiance)) else { continue };
                assert_eq!((a.wi, a.pdf, a.flags), (b.wi, b.pdf, b.flags));
                let want = if a.is_transmission() { a.f * TINT } else { a.f };
                seen_t |= a.is_transmission();
                seen_r |= !a.is_transmission();
                for k in 0..4 {
                    assert!((b.f[k] - want[k]).abs() <= 1e-6 * want[k].abs().max(1.0), "r {r}: {:?} vs {want:?}", b.f);
                }
            }
        }
        assert!(seen_t && seen_r);
    }
    // a tint above 1 would add light: clamped
    let t = clear(1.5, 0.0).tint_transmission(SampledSpectrum([2.0, 0.5, 1.0, 1.0])).unwrap();
    let s = t.sample_f(dir(0.0, 0.0), 0.99, Vec2::splat(0.5), TransportMode::Importance).unwrap();
    assert!(s.is_transmission());
    assert!((s.f[0] - s.f[2]).abs() < 1e-6 && (s.f[1] - 0.5 * s.f[2]).abs() < 1e-6);
}

#[test]
fn a_blend_at_either_end_is_the_part_itself() {
    let p = preview_params();
    let c = clear(1.5, 0.3);
    let wo = dir(40.0, 0.0);
    let wi = dir(150.0, 180.0);
    assert_eq!(Bsdf::blend(c, Bsdf::preview(p).unwrap(), 1.0).unwrap().f(wo, wi, TransportMode::Radiance), c.f(wo, wi, TransportMode::Radiance));
    let o = Bsdf::blend(c, Bsdf::preview(p).unwrap(), 0.0).unwrap();
    assert!(o.f(wo, wi, TransportMode::Radiance).is_black());
    assert_eq!(o.flags() & flags::TRANSMISSION, 0);
}

fn thin(transmission: f32, tint: SampledSpectrum, subsurface: f32, reflect: f32, transmit: SampledSpectrum) -> Option<preview::ThinWalled> {
    Some(preview::ThinWalled { transmission, tint, subsurface, reflect: grey(reflect), transmit })
}

/// The thin-wall configurations of the χ² and consistency tests (4 of them, 4 ωo each).
fn thin_configs() -> Vec<(&'static str, Bsdf)> {
    let base = preview_params();
    let green = SampledSpectrum([0.2, 0.9, 0.4, 0.6]);
    let p = |p: PreviewParams| Bsdf::preview(p).unwrap();
    vec![
        ("a leaf", p(PreviewParams { thin_walled: thin(0.0, grey(1.0), 1.0, 0.0, green), roughness: 0.4, ..base })),
        ("a coated leaf over a rough base", p(PreviewParams { thin_walled: thin(0.0, grey(1.0), 0.6, 0.3, green), diffuse_roughness: 0.5, clearcoat: 0.7, clearcoat_roughness: 0.3, ..base })),
        ("a frosted pane", p(PreviewParams { thin_walled: thin(0.7, TINT, 0.5, 0.0, grey(0.8)), roughness: 0.6, ..base })),
        ("a smooth pane over paper", p(PreviewParams { thin_walled: thin(0.5, grey(1.0), 1.0, 0.2, grey(0.5)), roughness: 0.0, metallic: 0.3, ..base })),
    ]
}

#[test]
fn chi2_thin_walls() {
    for (name, b) in thin_configs() {
        for wo in [dir(10.0, 0.0), dir(70.0, 30.0), dir(135.0, 10.0), dir(100.0, 0.0)] {
            check_chi2(name, &b, wo, TransportMode::Radiance);
            check_consistency(name, &b, wo, TransportMode::Radiance);
        }
    }
}

/// A white thin wall (white base, translucency and straight transmission, untinted) loses no
/// light: what its specular layer does not reflect crosses it or is reflected diffusely.
#[test]
fn furnace_thin_walls() {
    let white = grey(1.0);
    let base = PreviewParams { diffuse: white, base_for_metal: white, ..preview_params() };
    for (t, s, r) in [(0.0, 1.0, 0.0), (0.4, 0.5, 0.3), (1.0, 0.0, 0.0), (0.6, 1.0, 0.5)] {
        for roughness in [0.0, 0.4] {
            let p = PreviewParams { thin_walled: thin(t, white, s, r, grey(1.0 - r)), roughness, ..base };
            let b = Bsdf::preview(p).unwrap();
            for th in FURNACE_THETAS {
                for wo in [dir(th, 0.0), dir(180.0 - th, 0.0)] {
                    let (m, e) = furnace(&b, wo, TransportMode::Radiance, 20_000, false);
                    assert!((m - 1.0).abs() < COMPENSATION_TOL + 3.0 * e, "t {t} s {s} r {r} rough {roughness} wo {wo:?}: {m} ± {e}");
                }
            }
        }
    }
}

/// A smooth pane passes tint × (1 − F) straight through, F being its specular layer's Schlick
/// reflectance, along ω either way; the ray goes on unbent, and a shadow ray reads the same.
#[test]
fn a_smooth_pane_passes_what_it_does_not_reflect() {
    let p = PreviewParams { thin_walled: thin(1.0, TINT, 0.0, 0.0, grey(0.0)), roughness: 0.0, ..preview_params() };
    let b = Bsdf::preview(p).unwrap();
    let f0 = ((1.5f32 - 1.0) / (1.5 + 1.0)).powi(2);
    for th in [0.0f32, 30.0, 60.0, 85.0] {
        let wo = dir(th, 20.0);
        let want = TINT * (SampledSpectrum::ONE - fresnel_schlick(wo.z, grey(f0), grey(1.0)));
        for w in [wo, -wo] {
            let got = b.straight_through(w);
            for k in 0..4 {
                assert!((got[k] - want[k]).abs() < 1e-6, "θ {th}: {got:?} vs {want:?}");
            }
        }
        // the sampler's straight choice carries the same weight
        let mut rng = TestRng::new(3);
        let mut seen = false;
        for _ in 0..200 {
            let (uc, u) = rng_u(&mut rng);
            let s = b.sample_f(wo, uc, u, TransportMode::Radiance).unwrap();
            if s.is_transmission() {
                assert!(s.is_specular() && (s.wi + wo).length() < 1e-6 && s.eta == 1.0);
                let w = s.f * (s.wi.z.abs() / s.pdf);
                let want_w = want / s.pdf;
                for k in 0..4 {
                    assert!((w[k] - want_w[k]).abs() < 1e-5 * want_w[k].max(1.0), "θ {th}: {w:?} vs {want_w:?}");
                }
                seen = true;
            }
        }
        assert!(seen);
    }
}

/// A translucent wall scatters the same either way: f(ωo, ωi) = f(ωi, ωo) across it.
#[test]
fn translucency_is_reciprocal() {
    let p = PreviewParams { thin_walled: thin(0.0, grey(1.0), 0.7, 0.2, SampledSpectrum([0.3, 0.6, 0.9, 0.5])), roughness: 0.5, clearcoat: 0.5, ..preview_params() };
    let b = Bsdf::preview(p).unwrap();
    let mut rng = TestRng::new(9);
    for _ in 0..200 {
        let wo = crate::testing::random_upper(&mut rng);
        let wi = -crate::testing::random_upper(&mut rng);
        let (a, c) = (b.f(wo, wi, TransportMode::Radiance), b.f(wi, wo, TransportMode::Radiance));
        assert!(!a.is_black());
        for k in 0..4 {
            assert!((a[k] - c[k]).abs() <= 1e-5 * a[k].max(1e-3), "{a:?} vs {c:?}");
        }
    }
}
