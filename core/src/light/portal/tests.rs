//! Portals: the guided dome's sampling against its density (χ²), the irradiance it gives
//! against the unguided dome's, and how many samples the portals draw.

use crate::light::tests::{build, check_sampling, desc, hot_spot_texture, lambda, tilt};
use crate::light::{Light, LightSampleContext};
use crate::scene::{ColorSpace, LightShape, PortalDesc};
use crate::testing::chi2::TestRng;
use glam::{Mat4, Quat, Vec2, Vec3};

/// A window in the wall x = 2 letting light in towards −X (local +Z turned onto +X), and a
/// sheared, scaled skylight in the ceiling y = 2 letting it in downwards.
fn room_portals() -> Vec<PortalDesc> {
    let window = Mat4::from_rotation_translation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2), Vec3::new(2.0, 1.0, 0.3));
    let shear = Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.4, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    let skylight = Mat4::from_translation(Vec3::new(-0.5, 2.0, 0.2)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * shear * Mat4::from_scale(Vec3::new(1.5, 0.8, 1.0));
    vec![
        PortalDesc { name: "/Room/Window".into(), transform: window, width: 1.5, height: 1.0 },
        PortalDesc { name: "/Room/Skylight".into(), transform: skylight, width: 1.0, height: 1.0 },
    ]
}

fn guided(shape: LightShape, transform: Mat4, textures: &[crate::scene::TextureDesc]) -> Light {
    let mut d = desc(shape, transform);
    d.portals = room_portals();
    let mut l = Light::from_desc(&d, textures, ColorSpace::LinearRec709).unwrap();
    l.preprocess(Vec3::ZERO, 5.0);
    l
}

/// Whether unit `w` from `p` leaves through one of `room_portals()`.
fn through_a_portal(p: Vec3, w: Vec3) -> bool {
    let window = w.x > 0.0 && {
        let q = p + w * ((2.0 - p.x) / w.x);
        (q.y - 1.0).abs() <= 0.5 && (q.z - 0.3).abs() <= 0.75
    };
    // the skylight: X edge (1.5, 0, 0), Y edge (0.32, 0, −0.8) sheared, from the corner
    // (−1.41, 2, 0.6); the rectangle of its X edge and the Y edge's part square to it guides
    let sky = w.y > 0.0 && {
        let q = p + w * ((2.0 - p.y) / w.y);
        (-1.41..=0.09).contains(&q.x) && (-0.2..=0.6).contains(&q.z)
    };
    window || sky
}

#[test]
fn a_guided_dome_samples_as_its_density_says() {
    let inside = Vec3::new(0.2, 0.1, -0.3);
    let uniform = guided(LightShape::Dome { texture: None }, tilt(), &[]);
    let (integral, rate) = check_sampling("guided dome", &uniform, inside, 90);
    assert_eq!(rate, 1.0);
    assert!((integral - 1.0).abs() < 0.01);
    let tex = [hot_spot_texture()];
    let textured = guided(LightShape::Dome { texture: Some(0) }, tilt(), &tex);
    let (integral, _) = check_sampling("guided textured dome", &textured, inside, 91);
    assert!((integral - 1.0).abs() < 0.01);
    let sky = guided(crate::light::tests::sky_desc(30.0, 1.0).shape, tilt(), &[]);
    check_sampling("guided sky", &sky, inside, 92);
    // beyond the window (x > 2) no portal faces the receiver: the dome's own sampling
    let (integral, _) = check_sampling("guided dome outside", &uniform, Vec3::new(3.0, 1.0, 0.0), 93);
    assert!((integral - 1.0).abs() < 0.01);
}

#[test]
fn portals_change_what_a_dome_gives_by_no_more_than_noise() {
    // irradiance on a floor facing up, and the part of it that comes through the portals (as
    // a closed room would let it in), guided and not: the same expectations
    let lam = lambda();
    let tex = [hot_spot_texture()];
    let p = Vec3::new(0.2, 0.1, -0.3);
    for (name, shape, textures) in [("uniform", LightShape::Dome { texture: None }, &[][..]), ("textured", LightShape::Dome { texture: Some(0) }, &tex[..])] {
        let plain = Light::from_desc(&desc(shape.clone(), tilt()), textures, ColorSpace::LinearRec709).unwrap();
        let portal = guided(shape, tilt(), textures);
        let estimate = |l: &Light, seed: u64, through: bool| {
            let ctx = LightSampleContext::new(p, Vec3::Y);
            let mut rng = TestRng::new(seed);
            let n = 200_000;
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let x = match l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam) {
                    Some(s) if !through || through_a_portal(p, s.wi) => (s.l[0] * s.wi.y.max(0.0) / s.pdf) as f64,
                    _ => 0.0,
                };
                s1 += x;
                s2 += x * x;
            }
            let m = s1 / n as f64;
            (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
        };
        for through in [false, true] {
            let (a, sa) = estimate(&plain, 5, through);
            let (b, sb) = estimate(&portal, 6, through);
            let z = (a - b).abs() / (sa * sa + sb * sb).sqrt();
            assert!(z < 4.0, "{name} through {through}: {a} ± {sa} unguided vs {b} ± {sb} guided");
            if through {
                // what only the portals let in is found with far less noise through them
                assert!(sb < 0.5 * sa, "{name}: guided ± {sb} vs unguided ± {sa}");
            }
        }
    }
}

#[test]
fn portals_draw_their_share_of_a_uniform_domes_samples() {
    // uniform dome: a sample crosses a portal with probability share + (1 − share) Ω / 4π
    let l = guided(LightShape::Dome { texture: None }, Mat4::IDENTITY, &[]);
    let p = Vec3::new(0.2, 0.1, -0.3);
    let ctx = LightSampleContext::new(p, Vec3::ZERO);
    let lam = lambda();
    // the portals' solid angle from the density of a direction through one of them alone
    let Light::Dome(d) = &l else { unreachable!() };
    let ps = d.portals.as_deref().unwrap();
    let to_window = (Vec3::new(2.0, 1.0, 0.3) - p).normalize();
    let dome = 1.0 / (4.0 * std::f32::consts::PI);
    let omega = super::PORTAL_SHARE / ((ps.pdf(p, to_window, dome) - (1.0 - super::PORTAL_SHARE) * dome) as f64 as f32);
    let expected = (super::PORTAL_SHARE + (1.0 - super::PORTAL_SHARE) * omega * dome) as f64;
    let mut rng = TestRng::new(17);
    let n = 20_000;
    let crossed = (0..n).filter(|_| l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam).is_some_and(|s| through_a_portal(p, s.wi))).count();
    let f = crossed as f64 / n as f64;
    let sigma = (expected * (1.0 - expected) / n as f64).sqrt();
    assert!((f - expected).abs() < 4.0 * sigma, "{f} of samples through the portals, expected {expected} (Ω = {omega} sr)");
    assert!(omega > 0.1 && omega < 4.0, "{omega}");
}

#[test]
fn a_bad_portal_names_itself() {
    let mut d = desc(LightShape::Dome { texture: None }, Mat4::IDENTITY);
    d.portals = room_portals();
    d.portals[1].width = 0.0;
    let e = Light::from_desc(&d, &[], ColorSpace::LinearRec709).unwrap_err();
    assert!(e.starts_with("portals: '/Room/Skylight': size"), "{e}");
    d.portals[1].width = 1.0;
    d.portals[0].transform = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let e = Light::from_desc(&d, &[], ColorSpace::LinearRec709).unwrap_err();
    assert!(e.contains("'/Room/Window': transform"), "{e}");
    // portals on a light that is not a dome change nothing
    let mut sphere = desc(LightShape::Sphere { radius: 0.5, treat_as_point: false }, Mat4::IDENTITY);
    sphere.portals = room_portals();
    assert_eq!(build(&sphere), build(&desc(LightShape::Sphere { radius: 0.5, treat_as_point: false }, Mat4::IDENTITY)));
}

