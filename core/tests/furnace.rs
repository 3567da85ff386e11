//! White furnace: closed lossless objects in a uniform environment of radiance 1 must render
//! exactly 1 everywhere (energy neither lost nor gained), within a 3σ statistical bound.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::scene::*;

/// A unit sphere of `surface` (a UV sphere of `segments`) in a dome of radiance 1, seen from 4
/// units away with a 30° field of view.
fn furnace_scene(surface: SurfaceDesc, segments: u32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(uv_sphere("/sphere", 1.0, segments)));
    s.materials.push(MaterialDesc { name: "/m".into(), surface, interior_medium: None });
    s.instances_mut().push(instance("/sphere", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 30.0);
    s
}

fn furnace(surface: SurfaceDesc) -> (f64, f64, f64, f64) {
    let (w, h) = (24, 24);
    let r = render(&furnace_scene(surface, 48), settings(w, h, 64));
    // pixels well inside the sphere's silhouette (radius ≈ 0.26·fov ⇒ ~9 px of 24)
    let inside = |x: u32, y: u32| {
        let dx = x as f32 + 0.5 - 12.0;
        let dy = y as f32 + 0.5 - 12.0;
        dx * dx + dy * dy < 36.0
    };
    let (m, se, n) = channel_stats(&r, 1, inside, w);
    assert!(n > 80);
    let (mr, ser, _) = channel_stats(&r, 0, inside, w);
    (m, se, mr, ser)
}

fn check(name: &str, (m, se, mr, ser): (f64, f64, f64, f64)) {
    // 3σ of the estimated mean, plus 0.5% for the RGB→spectrum→RGB round trip of white
    // (the uplift of (1,1,1) is exactly constant; the CIE integration is MC and unbiased)
    eprintln!("{name}: G {m} ± {se}, R {mr} ± {ser}");
    for (v, e, ch) in [(m, se, "G"), (mr, ser, "R")] {
        assert!((v - 1.0).abs() < 3.0 * e + 0.005, "{name} {ch}: mean {v} ± {e}");
    }
}

#[test]
fn diffuse_albedo_one_sphere_renders_one() {
    check("diffuse", furnace(SurfaceDesc::Diffuse { color: ColorInput::Const([1.0; 3]) }));
}

#[test]
fn smooth_dielectric_sphere_renders_one() {
    check("smooth glass", furnace(SurfaceDesc::Water(WaterDesc { ior: 1.5, roughness: 0.0, ..Default::default() })));
}

#[test]
fn rough_dielectric_sphere_renders_one() {
    check("rough glass", furnace(SurfaceDesc::Water(WaterDesc { ior: 1.5, roughness: 0.6, ..Default::default() })));
}

#[test]
fn rough_water_sphere_renders_one() {
    check("rough water", furnace(SurfaceDesc::Water(WaterDesc { ior: 1.333, roughness: 0.3, ..Default::default() })));
}

/// Every pixel of a furnace reads 1, the sphere's rim too, where rays meet the interface at
/// grazing angles and light trapped inside by total internal reflection meets it many times:
/// the compensation's error compounds there (rough water at 0.3 read 1.024 at the rim and
/// 1.009 over the sphere with the albedo tables' coarser sampling, 1.0076 and 1.0053 in this
/// scene).
#[test]
fn rough_water_sphere_renders_one_to_its_rim() {
    let water = SurfaceDesc::Water(WaterDesc { ior: 1.333, roughness: 0.3, ..Default::default() });
    let (w, h) = (24, 24);
    let r = render(&furnace_scene(water, 96), settings(w, h, 512));
    // the silhouette's radius is about 9.4 px: the ring from 7 px out holds the rim
    let ring = |x: u32, y: u32| {
        let d = ((x as f32 + 0.5 - 12.0).powi(2) + (y as f32 + 0.5 - 12.0).powi(2)).sqrt();
        (7.0..10.0).contains(&d)
    };
    let whole = |x: u32, y: u32| ((x as f32 + 0.5 - 12.0).powi(2) + (y as f32 + 0.5 - 12.0).powi(2)).sqrt() < 10.0;
    for (name, region) in [("rim", &ring as &dyn Fn(u32, u32) -> bool), ("sphere", &whole)] {
        for ch in [0, 1] {
            let (m, se, n) = channel_stats(&r, ch, region, w);
            eprintln!("rough water {name} channel {ch}: {m} ± {se} over {n} pixels");
            // 3σ, plus 0.25% for the compensation tables' interpolation (up to 0.6% on one
            // interface at its worst angle; 0.1-0.2% over the sphere and its rim)
            assert!(n > 80 && (m - 1.0).abs() < 3.0 * se + 0.0025, "{name} channel {ch}: {m} ± {se}");
        }
    }
}

#[test]
fn sea_surface_sphere_never_gains_energy() {
    // the wind-driven sea BSDF has no multiple-scattering compensation yet (it loses up to
    // ~15% at grazing angles seen from below at high wind), so only the upper bound holds
    let (m, se, mr, ser) = furnace(SurfaceDesc::Water(WaterDesc { surface_model: SurfaceModel::Sea, wind_speed: 7.0, ..Default::default() }));
    eprintln!("sea: G {m} ± {se}, R {mr} ± {ser}");
    assert!(m < 1.0 + 3.0 * se + 0.005 && mr < 1.0 + 3.0 * ser + 0.005, "sea gains energy: {m} ± {se}");
    assert!(m > 0.8, "sea surface lost most of the light: {m}");
}

#[test]
fn dispersive_water_sphere_renders_one() {
    // Quan–Fry dispersion: each interface keeps only the hero wavelength; the estimate must
    // stay unbiased (the white furnace still renders 1)
    check("dispersive water", furnace(SurfaceDesc::Water(WaterDesc { dispersion: true, salinity: 35.0, temperature: 15.0, ..Default::default() })));
}
