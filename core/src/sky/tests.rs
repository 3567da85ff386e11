//! Tests of the sky module.
use super::*;
use glam::Vec3;

#[test]
fn explore() {
    let sky = HosekWilkieSky::with_frame(Vec3::Z, Vec3::new(0.6, 0.0, 0.8), 3.0, 0.3).unwrap();
    for b in 0..11 { println!("band {b} zen {}", sky.band_radiances(Vec3::Z)[b]); }
    println!("lum zen {}", sky.luminance(Vec3::Z));
    for l in [400.0, 450.0, 550.0, 650.0, 700.0] { println!("sun irr {l}: {} mean rad {}", sky.sun_irradiance(l), sky.sun_irradiance(l) as f64 / sun_solid_angle()); }
    println!("cd {}", cd_per_m2_per_unit_luminance());
    let s = SkySampler::new(&sky);
    println!("lumint {}", s.luminance_integral());
}
