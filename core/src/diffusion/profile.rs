//! The directional dipole BSSRDF (Frisvad, Hachisuka & Kjeldsen 2014) for one wavelength:
//! reduced coefficients, the boundary terms C_Φ and C_E by quadrature of the Fresnel
//! transmittance, the ray-source profile S'_d and its real/virtual source pair with the
//! modified tangent plane. Also the classical point-source dipole R_d(r) of Jensen et al.
//! (2001) with its closed-form total, and the BSSRDF built from it. [`ProfileModel`] picks
//! what a [`DipoleParams`] evaluates; the renderer uses the directional dipole normalised
//! to the classical total at normal incidence ([`NormTable`]), see `docs/diffusion.md`.

use crate::bsdf::fresnel::fresnel_dielectric;
use glam::Vec3;

const PI: f32 = std::f32::consts::PI;

/// C_Φ(η) = 1/4π ∫_H (1 − F_r) cosθ dω and C_E(η) = 3/4π ∫_H (1 − F_r) cos²θ dω for light
/// inside a body of relative IOR η (inside over outside) arriving at its boundary (the
/// Fresnel term crosses from η to 1: total internal reflection included). Index-matched
/// (η = 1): C_Φ = 1/4, C_E = 1/2.
pub fn boundary_terms(eta: f32) -> (f32, f32) {
    // midpoint rule in μ = cosθ, in f64; the integrands are bounded and the only kink is at
    // the critical angle, so 4096 cells give ~1e-7
    const N: usize = 4096;
    let (mut cphi, mut ce) = (0.0f64, 0.0f64);
    for k in 0..N {
        let mu = (k as f64 + 0.5) / N as f64;
        let t = 1.0 - fresnel_dielectric(mu as f32, 1.0 / eta) as f64;
        cphi += t * mu;
        ce += t * mu * mu;
    }
    // 1/4π · 2π ∫ … dμ and 3/4π · 2π ∫ … dμ
    ((0.5 * cphi / N as f64) as f32, (1.5 * ce / N as f64) as f32)
}

/// Which diffusion profile [`DipoleParams::eval`] evaluates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ProfileModel {
    /// The classical point-source dipole (Jensen et al. 2001): S_d = 1/(4C_Φ(1/η)) · R_d(r)/π.
    /// Its total diffuse reflectance is within a few per cent of a random walk in a
    /// half-space, single scattering included (unit tests), whatever the incident direction.
    #[default]
    Classical,
    /// The directional dipole (Frisvad et al. 2014), [`DipoleParams::sd`]. Direction-aware,
    /// but its total diffuse reflectance is 1.3–1.45× a random walk's (above 1 for α' → 1).
    Directional,
    /// The directional dipole scaled by [`DipoleParams::scale`] (set from a [`NormTable`]) so
    /// that its total diffuse reflectance for light along the normal of a half-space is the
    /// classical dipole's: the classical dipole's energy with the directional dipole's
    /// dependence on the incident direction and on the geometry (edges, curvature).
    DirectionalNormalized,
}

/// Per-wavelength constants of the dipole profiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DipoleParams {
    pub sigma_a: f32,
    /// Extinction σt = σa + σs (the backlit source distance uses it).
    pub sigma_t: f32,
    /// Reduced scattering σs' = σs (1 − g).
    pub sigma_s_r: f32,
    /// Reduced extinction σt' = σa + σs'.
    pub sigma_t_r: f32,
    /// Reduced albedo α' = σs'/σt'.
    pub albedo_r: f32,
    /// Diffusion coefficient D = (2σa + σs') / (3σt'²) (Grosjean's, as the paper uses).
    pub d: f32,
    /// Effective transport coefficient σtr = √(σa / D).
    pub sigma_tr: f32,
    /// Extrapolation distance d_e = 2.131 D / √α'.
    pub de: f32,
    /// Reflection parameter A = (1 − C_E(η)) / (2 C_Φ(η)).
    pub a: f32,
    pub c_phi: f32,
    pub c_e: f32,
    /// 1 / (4 C_Φ(1/η)): exitance to radiance through the boundary.
    pub norm: f32,
    /// The profile [`DipoleParams::eval`] uses.
    pub model: ProfileModel,
    /// Factor on the directional dipole for [`ProfileModel::DirectionalNormalized`] (1 until
    /// set from a [`NormTable`]).
    pub scale: f32,
}

impl DipoleParams {
    /// Constants for absorption σa, scattering σs (per scene unit), mean cosine g and the
    /// relative IOR η of the boundary. None when the medium cannot diffuse (σt' = 0).
    pub fn new(sigma_a: f32, sigma_s: f32, g: f32, eta: f32) -> Option<Self> {
        let (cphi, ce) = boundary_terms(eta);
        let (cphi_out, _) = boundary_terms(1.0 / eta);
        Self::with_terms(sigma_a, sigma_s, g, cphi, ce, cphi_out)
    }

    /// [`DipoleParams::new`] with the boundary terms C_Φ(η), C_E(η), C_Φ(1/η) given (they
    /// depend on η only, so a caller evaluating many wavelengths computes them once).
    pub fn with_terms(sigma_a: f32, sigma_s: f32, g: f32, c_phi: f32, c_e: f32, c_phi_out: f32) -> Option<Self> {
        let sigma_a = sigma_a.max(0.0);
        let sigma_s_r = (sigma_s * (1.0 - g)).max(0.0);
        let sigma_t_r = sigma_a + sigma_s_r;
        if !(sigma_t_r > 0.0) || !(sigma_s_r > 0.0) || !sigma_t_r.is_finite() {
            return None;
        }
        let albedo_r = sigma_s_r / sigma_t_r;
        let d = (2.0 * sigma_a + sigma_s_r) / (3.0 * sigma_t_r * sigma_t_r);
        let sigma_tr = (sigma_a / d).sqrt();
        let de = 2.131 * d / albedo_r.sqrt();
        let a = (1.0 - c_e) / (2.0 * c_phi);
        Some(DipoleParams { sigma_a, sigma_t: sigma_a + sigma_s.max(0.0), sigma_s_r, sigma_t_r, albedo_r, d, sigma_tr, de, a, c_phi, c_e, norm: 1.0 / (4.0 * c_phi_out), model: ProfileModel::default(), scale: 1.0 })
    }

    /// The same constants evaluating `model`.
    pub fn with_model(self, model: ProfileModel) -> Self {
        DipoleParams { model, ..self }
    }

    /// S_d(x_i, ω_i; x_o) of the chosen [`ProfileModel`] (arguments as for [`DipoleParams::sd`]).
    #[inline]
    pub fn eval(&self, xi: Vec3, ni: Vec3, w12: Vec3, xo: Vec3, no: Vec3) -> f32 {
        match self.model {
            ProfileModel::Classical => self.classic_sd((xo - xi).length()),
            ProfileModel::Directional => self.sd(xi, ni, w12, xo, no),
            ProfileModel::DirectionalNormalized => self.scale * self.sd_floored(xi, ni, w12, xo, no, NEAR_FIELD_MFP / self.sigma_t_r),
        }
    }

    /// The directional dipole's total diffuse reflectance for light entering a half-space
    /// along its normal: the flux leaving (Fresnel included) per unit flux entering,
    /// π/norm · ∫ S_d dA, by quadrature on a log grid in r (midpoint in ln r, f64 sums).
    /// It depends on α' and η only (every length scales with 1/σt').
    pub fn directional_total(&self, dr_min: f32) -> f32 {
        const N: usize = 4000;
        let n = Vec3::Y;
        let r_min = 1e-6 / self.sigma_t_r as f64;
        // beyond 60 diffusion lengths e^{−σtr r} < 1e-26; the dipole pair falls like 1/r³
        // besides, so 1e4 mean free paths bound the range when σtr is tiny
        let r_max = (60.0 / self.sigma_tr as f64).min(1e4 / self.sigma_t_r as f64);
        let (a, b) = (r_min.ln(), r_max.ln());
        let h = (b - a) / N as f64;
        let mut s = 0.0f64;
        for k in 0..N {
            let r = (a + h * (k as f64 + 0.5)).exp();
            s += self.sd_floored(Vec3::ZERO, n, -n, Vec3::new(r as f32, 0.0, 0.0), n, dr_min) as f64 * r * r;
        }
        (2.0 * PI as f64 * s * h * PI as f64 / self.norm as f64) as f32
    }

    /// The classical dipole's BSSRDF S_d(r) = 1/(4C_Φ(1/η)) · R_d(r)/π (without the two
    /// Fresnel transmittances): the exitance R_d(r) leaves with the angular distribution
    /// F_t(ω_o)·cosθ_o, normalised so that the flux leaving is R_d itself.
    #[inline]
    pub fn classic_sd(&self, r: f32) -> f32 {
        self.norm / PI * classic_rd(self.sigma_a, self.sigma_s_r, self.a, r)
    }

    /// The ray-source term S'_d(x, ω, r) at an exit point with normal `no`: `x` from the
    /// source to the exit point, `w` the source direction, `r` the (offset) distance.
    #[inline]
    pub fn s_prime(&self, x: Vec3, w: Vec3, r: f32, no: Vec3) -> f32 {
        let str_ = self.sigma_tr * r;
        let one = 1.0 + str_;
        let xw = x.dot(w);
        let r2 = r * r;
        let t0 = self.norm / (4.0 * PI * PI) * (-str_).exp() / (r2 * r);
        let t1 = self.c_phi * (r2 / self.d + 3.0 * one * xw);
        let t2 = 3.0 * self.d * one * w.dot(no);
        let t3 = (one + 3.0 * self.d * (3.0 * one + str_ * str_) / r2 * xw) * x.dot(no);
        t0 * (t1 - self.c_e * (t2 - t3))
    }

    /// The diffuse directional-dipole BSSRDF S_d(x_i, ω_i; x_o) (per unit area and solid
    /// angle, without the two Fresnel transmittances): light entering at `xi` (normal `ni`,
    /// outward) travelling along `w12` (the refracted direction, into the body), leaving at
    /// `xo` (normal `no`, outward). Negative values of the model are clamped to 0.
    pub fn sd(&self, xi: Vec3, ni: Vec3, w12: Vec3, xo: Vec3, no: Vec3) -> f32 {
        self.sd_floored(xi, ni, w12, xo, no, 0.0)
    }

    /// [`DipoleParams::sd`] with the distance to the real source kept at least `dr_min`.
    pub fn sd_floored(&self, xi: Vec3, ni: Vec3, w12: Vec3, xo: Vec3, no: Vec3, dr_min: f32) -> f32 {
        let x = xo - xi;
        let r2 = x.length_squared();
        let r = r2.sqrt();
        // the modified tangent plane: contains x and is perpendicular to the plane of x and ni
        let ni_s = if r > 1e-7 * (1.0 + xo.abs().max_element()) {
            let c = ni.cross(x);
            let cl = c.length();
            if cl > 1e-7 * r {
                (x / r).cross(c / cl)
            } else {
                ni
            }
        } else {
            ni
        };
        let wv = w12 - 2.0 * w12.dot(ni_s) * ni_s;
        let mu0 = -no.dot(w12);
        let xw = x.dot(w12);
        let dr2 = if mu0 > 0.0 {
            let cos_beta = -((r2 - xw * xw).max(0.0) / (r2 + self.de * self.de)).sqrt();
            let dm = self.d * mu0;
            r2 + dm * (dm - 2.0 * self.de * cos_beta)
        } else {
            r2 + 1.0 / (9.0 * self.sigma_t * self.sigma_t)
        };
        let dr = dr2.max(1e-20).max(dr_min * dr_min).sqrt();
        let xv = xi + 2.0 * self.a * self.de * ni_s;
        let xov = xo - xv;
        let dv = xov.length().max(1e-10);
        let s = self.s_prime(x, w12, dr, no) - self.s_prime(xov, wv, dv, no);
        if s.is_finite() {
            s.max(0.0)
        } else {
            0.0
        }
    }
}

/// Fluence of a unit ray source (a point source plus its first-order dipole moment along
/// `w`) in an infinite medium at offset `x` from it: φ = e^{−σtr r}/(4πD r) · (1 + 3D(1 + σtr r) x·w / r²).
pub fn ray_source_fluence(p: &DipoleParams, x: Vec3, w: Vec3) -> f32 {
    let r = x.length();
    let str_ = p.sigma_tr * r;
    (-str_).exp() / (4.0 * PI * p.d * r) * (1.0 + 3.0 * p.d * (1.0 + str_) * x.dot(w) / (r * r))
}

/// Classical dipole diffuse reflectance profile R_d(r) (Jensen et al. 2001) with
/// D = 1/(3σt'), z_r = 1/σt', z_v = z_r + 4AD, σtr = √(3σa σt').
pub fn classic_rd(sigma_a: f32, sigma_s_r: f32, a: f32, r: f32) -> f32 {
    let st = sigma_a + sigma_s_r;
    let alpha = sigma_s_r / st;
    let d = 1.0 / (3.0 * st);
    let s_tr = (3.0 * sigma_a * st).sqrt();
    let zr = 1.0 / st;
    let zv = zr + 4.0 * a * d;
    let dr = (r * r + zr * zr).sqrt();
    let dv = (r * r + zv * zv).sqrt();
    alpha / (4.0 * PI) * (zr * (s_tr * dr + 1.0) * (-s_tr * dr).exp() / (dr * dr * dr) + zv * (s_tr * dv + 1.0) * (-s_tr * dv).exp() / (dv * dv * dv))
}

/// Total diffuse reflectance of the classical dipole, ∫ R_d(r) 2πr dr in closed form:
/// (α'/2)(1 + e^{−(4/3)A√(3(1−α'))}) e^{−√(3(1−α'))}.
pub fn classic_rd_total(albedo_r: f32, a: f32) -> f32 {
    let s = (3.0 * (1.0 - albedo_r)).sqrt();
    0.5 * albedo_r * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp()
}

/// Least distance to the real source of [`ProfileModel::DirectionalNormalized`], in reduced
/// mean free paths. The published model puts the real source on the surface at a distance
/// D·μ0 (1/3 mean free path along the normal, → 0 for grazing light) or 1/(3σt) (light from
/// a face across an edge), so its peak can be far narrower than the renderer's points (half
/// a mean free path apart; the tree integrates the points next to the exit point over their
/// patches, `NEAR_PATCHES`, which resolves ~1/6 mean free path): without a floor, exit points
/// next to a point glowed. 0.1 leaves light entering at cosθ ≥ 0.3 (inside) untouched;
/// diffusion does not hold that close to the source anyway. The factor of [`NormTable`] is
/// computed with the same floor, so the total at normal incidence is kept.
pub const NEAR_FIELD_MFP: f32 = 0.1;

/// Nodes of a [`NormTable`], uniform in u = √(3(1 − α')) over [U_MIN, U_MAX].
const NORM_NODES: usize = 64;
/// α' = 0.9999: the table's high-albedo end (σtr/σt' = 0.017).
const NORM_U_MIN: f32 = 0.017_320_5;
/// α' ≈ 0.03: the low-albedo end (diffusion has long stopped holding there).
const NORM_U_MAX: f32 = 1.705;

/// The factors of [`ProfileModel::DirectionalNormalized`] for one boundary (C_Φ(η), C_E(η),
/// C_Φ(1/η)) over the reduced albedo: classical total / directional total at normal
/// incidence, tabulated in u = √(3(1 − α')) (the totals' natural variable: both go like
/// e^{−u}) and interpolated linearly.
#[derive(Clone, Debug, PartialEq)]
pub struct NormTable {
    ratio: [f32; NORM_NODES],
}

impl NormTable {
    /// Tabulates the ratio for a boundary with the given terms (~0.3 M profile evaluations).
    pub fn new(c_phi: f32, c_e: f32, c_phi_out: f32) -> Self {
        let ratio = std::array::from_fn(|k| {
            let u = NORM_U_MIN + (NORM_U_MAX - NORM_U_MIN) * k as f32 / (NORM_NODES - 1) as f32;
            let alpha = 1.0 - u * u / 3.0;
            match DipoleParams::with_terms(1.0 - alpha, alpha, 0.0, c_phi, c_e, c_phi_out) {
                Some(p) => {
                    let dir = p.directional_total(NEAR_FIELD_MFP / p.sigma_t_r);
                    if dir > 0.0 {
                        classic_rd_total(alpha, p.a) / dir
                    } else {
                        1.0
                    }
                }
                None => 1.0,
            }
        });
        NormTable { ratio }
    }

    /// The factor for reduced albedo `albedo_r` (clamped to the table's range).
    pub fn scale(&self, albedo_r: f32) -> f32 {
        let u = (3.0 * (1.0 - albedo_r).max(0.0)).sqrt();
        let x = ((u - NORM_U_MIN) / (NORM_U_MAX - NORM_U_MIN) * (NORM_NODES - 1) as f32).clamp(0.0, (NORM_NODES - 1) as f32);
        let i = (x as usize).min(NORM_NODES - 2);
        let f = x - i as f32;
        self.ratio[i] * (1.0 - f) + self.ratio[i + 1] * f
    }
}
