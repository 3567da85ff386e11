//! Tests of the LM-63 reader: values at the file's angles, bilinear interpolation between
//! them, each symmetry unfolded, the normalisation integral against closed forms, TILT data,
//! the factors that scale the candela, and the errors of malformed files.

use super::*;

/// An LM-63-2002 file of type C with the given angles (degrees) and candela rows (one per
/// horizontal angle), candela multiplier 2, ballast factor 0.5 and ballast-lamp factor 1 (so
/// the values read back as written).
pub(crate) fn file(v: &[f64], h: &[f64], rows: &[Vec<f64>]) -> String {
    file_of_type(1, v, h, rows)
}

/// [`file`] of photometric type `kind` (1 C, 2 B, 3 A).
fn file_of_type(kind: u32, v: &[f64], h: &[f64], rows: &[Vec<f64>]) -> String {
    let join = |a: &[f64]| a.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
    let mut s = String::from("IESNA:LM-63-2002\n[TEST] synthetic\n[MANUFAC] none\nTILT=NONE\n");
    s += &format!("1 -1 2.0 {} {} {kind} 2 0.1 0.1 0.0\n0.5 1.0 10\n", v.len(), h.len());
    s += &join(v);
    s += "\n";
    s += &join(h);
    s += "\n";
    for r in rows {
        // values wrapped over lines and separated by commas too, as real files do
        s += &r.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ");
        s += "\n";
    }
    s
}

fn deg(x: f32) -> f32 {
    x.to_radians()
}

#[test]
fn values_at_the_files_angles_and_between_them() {
    let p = IesProfile::parse(&file(&[0.0, 30.0, 60.0, 90.0], &[0.0], &[vec![100.0, 80.0, 40.0, 0.0]])).unwrap();
    for (v, want) in [(0.0, 100.0), (30.0, 80.0), (60.0, 40.0), (90.0, 0.0), (45.0, 60.0), (10.0, 100.0 - 20.0 / 3.0)] {
        for h in [0.0, 77.0, 200.0] {
            let got = p.eval(deg(v), deg(h));
            assert!((got - want as f32).abs() < 1e-3, "v {v} h {h}: {got} vs {want}");
        }
    }
    // above the horizon of a downlight-only file: dark
    assert_eq!(p.eval(deg(100.0), 0.0), 0.0);
    assert!(p.is_axial());
}

#[test]
fn symmetries_unfold_the_horizontal_angles() {
    let v = [0.0, 90.0, 180.0];
    let row = |a: f64| vec![a, a + 1.0, a + 2.0];
    // quadrant: 0..90
    let q = IesProfile::parse(&file(&v, &[0.0, 45.0, 90.0], &[row(10.0), row(20.0), row(30.0)])).unwrap();
    let at = |p: &IesProfile, h: f32| p.eval(deg(90.0), deg(h));
    assert!((at(&q, 45.0) - 21.0).abs() < 1e-4);
    for (h, mirror) in [(135.0, 45.0), (180.0, 0.0), (200.0, 20.0), (300.0, 60.0), (350.0, 10.0)] {
        assert!((at(&q, h) - at(&q, mirror)).abs() < 1e-4, "quadrant {h}");
    }
    // bilateral about the 0–180 plane
    let b = IesProfile::parse(&file(&v, &[0.0, 90.0, 180.0], &[row(10.0), row(20.0), row(60.0)])).unwrap();
    for (h, mirror) in [(270.0, 90.0), (200.0, 160.0), (359.0, 1.0)] {
        assert!((at(&b, h) - at(&b, mirror)).abs() < 1e-3, "bilateral {h}");
    }
    assert!((at(&b, 135.0) - 41.0).abs() < 1e-4);
    // bilateral about the 90–270 plane
    let b9 = IesProfile::parse(&file(&v, &[90.0, 180.0, 270.0], &[row(10.0), row(20.0), row(60.0)])).unwrap();
    for (h, mirror) in [(0.0, 180.0), (45.0, 135.0), (300.0, 240.0)] {
        assert!((at(&b9, h) - at(&b9, mirror)).abs() < 1e-3, "bilateral 90 {h}");
    }
    // full, not ending at 360: from the last angle back round to the first
    let f = IesProfile::parse(&file(&v, &[0.0, 120.0, 240.0], &[row(10.0), row(40.0), row(70.0)])).unwrap();
    assert!((at(&f, 300.0) - 41.0).abs() < 1e-3, "{}", at(&f, 300.0));
    assert!((at(&f, 60.0) - 26.0).abs() < 1e-3);
    assert!(!f.is_axial());
}

#[test]
fn the_mean_intensity_matches_closed_forms() {
    // constant over the sphere: the constant
    let c = IesProfile::parse(&file(&[0.0, 180.0], &[0.0], &[vec![7.0, 7.0]])).unwrap();
    assert!((c.mean_intensity() - 7.0).abs() < 1e-4);
    // a downlight-only file averages over the hemisphere: I = 100 cos v tabulated every degree
    // gives ∫cos dω / 2π = 1/2, so 50 (up to the interpolation's chord error, ~1e-5)
    let v: Vec<f64> = (0..=90).map(|d| d as f64).collect();
    let cos: Vec<f64> = v.iter().map(|d| 100.0 * d.to_radians().cos()).collect();
    let p = IesProfile::parse(&file(&v, &[0.0], &[cos])).unwrap();
    assert!((p.mean_intensity() - 50.0).abs() < 5e-3, "{}", p.mean_intensity());
    // a quadrant file varying with h only, 10 → 15 → 20 from 0° to 45° to 90°: its
    // interpolant is linear in h, mirrored in every quadrant, so its mean is 15
    let q = IesProfile::parse(&file(&[0.0, 180.0], &[0.0, 45.0, 90.0], &[vec![10.0, 10.0], vec![15.0, 15.0], vec![20.0, 20.0]])).unwrap();
    assert!((q.mean_intensity() - 15.0).abs() < 1e-3, "{}", q.mean_intensity());
}

#[test]
fn tilt_data_and_the_candela_factors() {
    let text = "IESNA91\nTILT=INCLUDE\n1\n3\n0 45 90\n1.0 0.9 0.8\n1 1000 3.0 2 1 1 2 0 0 0\n2.0 0.5 40\n0 90\n0\n5 7\n";
    let p = IesProfile::parse(text).unwrap();
    // 5 × multiplier 3 × ballast 2 × ballast-lamp 0.5
    assert!((p.eval(0.0, 0.0) - 15.0).abs() < 1e-5);
    // older files without the IESNA line, values split over lines
    let text = "some description\nTILT=NONE\n1 -1 1\n2 1 1 2 0 0 0 1 1 0\n0\n90\n0\n4\n6\n";
    assert!((IesProfile::parse(text).unwrap().eval(deg(45.0), 0.0) - 5.0).abs() < 1e-5);
}

#[test]
fn malformed_files_are_errors_saying_why() {
    let good = file(&[0.0, 90.0], &[0.0], &[vec![1.0, 2.0]]);
    let cases = [
        (good.replace("TILT=NONE", "TILTED"), "TILT"),
        (good.replace(" 1 2 0.1", " 4 2 0.1"), "type 4 is none of"),
        (file_of_type(2, &[0.0, 100.0], &[0.0], &[vec![1.0, 2.0]]), "[-90, 90] degrees for type B"),
        (file_of_type(3, &[0.0, 90.0], &[-100.0, 0.0], &[vec![1.0, 2.0], vec![1.0, 2.0]]), "horizontal angles must lie in [-90, 90] degrees for type A"),
        (good.replace("1, 2\n", "1\n"), "ends before the candela values"),
        (good.replace("\n0 90\n", "\n90 0\n"), "vertical angles must increase"),
        (good.replace("1, 2\n", "1, x\n"), "'x' is not a number"),
        (good.replace("\n0 90\n", "\n0 190\n"), "[0, 180]"),
    ];
    for (text, want) in cases {
        let e = IesProfile::parse(&text).unwrap_err();
        assert!(e.contains(want), "{want}: {e}");
    }
}

/// Types B and A: a profile written on their grids as a function of the angle from the axis
/// alone (cos ψ = cos H cos V for both) reads back as that function of the vertical angle `v`
/// in every direction in front of the light, and nothing behind it; the mean over the
/// hemisphere matches the closed form.
#[test]
fn types_b_and_a_read_their_angles_about_the_axis() {
    let grid: Vec<f64> = (0..=180).map(|i| -90.0 + i as f64).collect();
    let rows: Vec<Vec<f64>> = grid.iter().map(|h| grid.iter().map(|v| 100.0 * h.to_radians().cos() * v.to_radians().cos()).collect()).collect();
    let mut rng = crate::testing::chi2::TestRng::new(5);
    for kind in [2, 3] {
        let p = IesProfile::parse(&file_of_type(kind, &grid, &grid, &rows)).unwrap();
        assert!(!p.is_axial());
        for _ in 0..500 {
            let (v, h) = (rng.next_f32() * std::f32::consts::PI, rng.next_f32() * 2.0 * std::f32::consts::PI);
            let want = 100.0 * v.cos().max(0.0);
            // bilinear over 1° cells of a cosine: within 0.02 cd
            assert!((p.eval(v, h) - want).abs() < 0.02, "type {kind} at v {v} h {h}: {} vs {want}", p.eval(v, h));
        }
        // (1/2π) ∫ 100 cos ψ over the front hemisphere = 50
        assert!((p.mean_intensity() - 50.0).abs() < 0.05, "type {kind} mean {}", p.mean_intensity());
    }
}

/// Which way a type B or A file's angles turn: an asymmetric B profile brightens towards +X,
/// an A profile towards +Y; a 0–90° horizontal range is mirrored; a 0–90° vertical range
/// leaves the other side dark.
#[test]
fn types_b_and_a_turn_towards_x_and_y() {
    let h: Vec<f64> = (0..=18).map(|i| -90.0 + 10.0 * i as f64).collect();
    let v = [-90.0, 0.0, 90.0];
    let rows: Vec<Vec<f64>> = h.iter().map(|h| vec![100.0 + 50.0 * h.to_radians().sin(); 3]).collect();
    let b = IesProfile::parse(&file_of_type(2, &v, &h, &rows)).unwrap();
    let a = IesProfile::parse(&file_of_type(3, &v, &h, &rows)).unwrap();
    // 30° from the axis towards +X (h = 0) and towards +Y (h = 90°)
    let (toward_x, toward_y) = ((deg(30.0), 0.0), (deg(30.0), deg(90.0)));
    let sin30 = 50.0 * 0.5;
    assert!((b.eval(toward_x.0, toward_x.1) - (100.0 + sin30)).abs() < 0.5, "{}", b.eval(toward_x.0, toward_x.1));
    assert!((b.eval(deg(30.0), deg(180.0)) - (100.0 - sin30)).abs() < 0.5);
    assert!((b.eval(toward_y.0, toward_y.1) - 100.0).abs() < 1e-3, "a B file's planes turn about Y");
    assert!((a.eval(toward_y.0, toward_y.1) - (100.0 + sin30)).abs() < 0.5, "{}", a.eval(toward_y.0, toward_y.1));
    assert!((a.eval(toward_x.0, toward_x.1) - 100.0).abs() < 1e-3, "an A file's planes turn about X");
    // mirrored horizontal angles; a vertical range of 0–90° lights one side only
    let half: Vec<f64> = h.iter().copied().filter(|&x| x >= 0.0).collect();
    let m = IesProfile::parse(&file_of_type(2, &[0.0, 90.0], &half, &vec![vec![100.0, 100.0]; half.len()])).unwrap();
    // (towards +X and −X, both a little towards +Y)
    assert_eq!(m.eval(deg(40.0), deg(10.0)), m.eval(deg(40.0), deg(170.0)));
    assert!(m.eval(deg(40.0), deg(10.0)) > 99.0);
    let mirrored_y = m.eval(deg(40.0), deg(-90.0));
    assert!(mirrored_y == 0.0, "below the B file's 0° elevation is dark: {mirrored_y}");
    // behind the light: dark
    assert_eq!(b.eval(deg(120.0), 0.0), 0.0);
}
