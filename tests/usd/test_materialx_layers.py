"""The layers of MaterialX's PBR surfaces beyond UsdPreviewSurface's: the specular's weight
and tint, the coat's colour, IOR and darkening, specular anisotropy and its direction. Each is checked
against what its definition implies (Fresnel reflectance at normal incidence, a colour
multiplying what lies beneath, a highlight stretched along the tangent)."""
import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from conftest import HALF, RES, bind, near, panel, render, settings, shader_node, top_camera, white_dome


def _surface(stage, node_id, **inputs):
    """A Material at /Looks/M whose mtlx:surface is a `node_id` shader with `inputs`."""
    mat = UsdShade.Material.Define(stage, "/Looks/M")
    sh = shader_node(stage, "/Looks/M/S", node_id, **inputs)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(sh.CreateOutput("out", Sdf.ValueTypeNames.Token))
    return mat


def _seen_from_above(renderer, stage, mat, samples=16):
    """The mean colour of a panel bound to `mat` under the white dome, seen straight down with
    one bounce; the material raises no problem."""
    top_camera(stage)
    white_dome(stage)
    m = panel(stage, "/Panel")
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=samples, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3]
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    return img


def _f0(ior):
    return ((ior - 1) / (ior + 1)) ** 2


def test_a_weighted_tinted_specular_reflects_weight_times_tint_times_fresnel(renderer, stage):
    """A black base under a smooth specular of IOR 3 (F0 = 1/4) with weight 0.6 and colour
    (1, 0.5, 0.25), seen at normal incidence under a dome of radiance 1: 0.6 x colour x F0.
    Untinted it would be grey 0.15."""
    tint = np.array([1.0, 0.5, 0.25])
    mat = _surface(stage, "ND_standard_surface_surfaceshader", base=0.0, specular=0.6,
                   specular_color=tuple(tint), specular_roughness=0.0, specular_IOR=3.0)
    img = _seen_from_above(renderer, stage, mat)
    ok, why = near(img, 0.6 * _f0(3.0) * tint)
    assert ok, why


def test_a_coat_colour_tints_what_lies_beneath(renderer):
    """A white diffuse base under a smooth coat: the coat mirrors F0 = 0.04 of the dome, and
    whatever comes from under it is multiplied by the coat's colour, so (coloured − 0.04) =
    colour x (clear − 0.04)."""
    def look(colour):
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        mat = _surface(stage, "ND_standard_surface_surfaceshader", base=1.0,
                       base_color=(1.0, 1.0, 1.0), specular=0.0, coat=1.0, coat_roughness=0.0,
                       coat_color=tuple(colour))
        return _seen_from_above(renderer, stage, mat, samples=32).reshape(-1, 3)

    colour = np.array([0.2, 0.5, 0.8])
    clear, tinted = look((1, 1, 1)), look(colour)
    under = clear.mean(axis=0) - _f0(1.5)
    assert np.all(under > 0.8), under
    ok, why = near(tinted - _f0(1.5), colour * under)
    assert ok, why


def test_an_open_pbr_coat_has_its_own_ior(renderer, stage):
    """OpenPBR's coat_ior defaults to 1.6: over a black base with no specular, a smooth coat
    mirrors F0 = (0.6 / 2.6)^2 = 0.0533 of the dome (a coat of UsdPreviewSurface's 1.5 would
    give 0.04); coat_ior 2 gives 1/9."""
    for ior in (None, 2.0):
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        inputs = dict(base_weight=0.0, specular_weight=0.0, coat_weight=1.0, coat_roughness=0.0)
        if ior is not None:
            inputs["coat_ior"] = ior
        img = _seen_from_above(renderer, s, _surface(s, "ND_open_pbr_surface_surfaceshader", **inputs))
        ok, why = near(img, [_f0(ior or 1.6)] * 3)
        assert ok, (ior, why)


def test_an_open_pbr_coat_darkens_what_lies_beneath(renderer):
    """OpenPBR's coat darkening (on by default): under a smooth coat of IOR 1.6, whose
    underside sends back K = 1 - (1 - F0) / 1.6^2 of the light the base reflects, a grey base
    of colour 0.5 shows (1 - K) / (1 - 0.5 K) = 0.540 of what it shows with coat_darkening 0;
    the coat's own reflection (a black base) is left as it is."""
    def look(**inputs):
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        mat = _surface(stage, "ND_open_pbr_surface_surfaceshader", base_color=(0.5, 0.5, 0.5),
                       specular_weight=0.0, coat_weight=1.0, coat_roughness=0.0, **inputs)
        px = _seen_from_above(renderer, stage, mat, samples=32).reshape(-1, 3).astype(np.float64)
        return px.mean(axis=0), px.std(axis=0, ddof=1) / np.sqrt(len(px))

    k = 1 - (1 - _f0(1.6)) / 1.6 ** 2
    want = (1 - k) / (1 - 0.5 * k)
    (dark, se_d), (plain, se_p), (coat, se_c) = look(), look(coat_darkening=0.0), look(base_weight=0.0)
    assert np.all(plain - coat > 0.3), (plain, coat)
    expect = coat + want * (plain - coat)
    se = np.sqrt(se_d ** 2 + (want * se_p) ** 2 + ((1 - want) * se_c) ** 2)
    assert np.all(np.abs(dark - expect) < 4 * se + 1e-3), (dark, expect, se)


def _highlight_spread(renderer, rotation):
    """Second moments (along x, along z) of the highlight a small light straight above the
    centre makes on a rough anisotropic white metal panel whose u runs along +x."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    top_camera(stage)
    m = panel(stage, "/Panel", columns=1, st=True)  # u along x, v along z
    light = UsdLux.SphereLight.Define(stage, "/Light")
    light.CreateRadiusAttr(0.02)
    light.CreateIntensityAttr(2000.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0, 1.0, 0))
    mat = _surface(stage, "ND_standard_surface_surfaceshader", base=1.0, base_color=(1.0, 1.0, 1.0),
                   metalness=1.0, specular_roughness=0.35, specular_anisotropy=0.8,
                   specular_rotation=rotation)
    bind(m.GetPrim(), mat)
    settings(stage, res=(RES, RES), samples=32, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3].astype(np.float64).mean(axis=-1)
    assert [p for p in problems if p.prim.startswith("/Looks")] == [], problems
    # rows follow z, columns x (top_camera)
    c = -HALF + (np.arange(RES) + 0.5) * 2 * HALF / RES
    w = img / img.sum()
    return float((w * c[None, :] ** 2).sum()), float((w * c[:, None] ** 2).sum())


def test_anisotropy_stretches_the_highlight_along_the_turned_tangent(renderer):
    """specular_anisotropy 0.8 (α along the tangent 2.2 times α across it): with no turn the
    highlight spreads along u (x) more than along v (z); a quarter turn swaps the two, the
    spreads trading places (the scene is symmetric under x <-> z)."""
    x0, z0 = _highlight_spread(renderer, 0.0)
    x1, z1 = _highlight_spread(renderer, 0.25)
    assert x0 > 1.5 * z0, (x0, z0)
    assert z1 > 1.5 * x1, (x1, z1)
    assert abs(x0 / z1 - 1) < 0.1 and abs(z0 / x1 - 1) < 0.1, (x0, z0, x1, z1)


def test_a_rough_diffuse_base_seen_head_on_reflects_oren_nayar_a(renderer, stage):
    """Standard Surface's diffuse_roughness is Oren and Nayar's qualitative model with sigma =
    the roughness: seen at normal incidence under a uniform dome, the B term vanishes (tan of
    the smaller angle is 0) and a white base reflects A = 1 - 0.5 s^2 / (s^2 + 0.33): 0.7845
    at 0.5, where a Lambertian one reflects 1."""
    s = 0.5
    mat = _surface(stage, "ND_standard_surface_surfaceshader", base=1.0, base_color=(1.0, 1.0, 1.0),
                   specular=0.0, diffuse_roughness=s)
    img = _seen_from_above(renderer, stage, mat)
    ok, why = near(img, [1 - 0.5 * s * s / (s * s + 0.33)] * 3)
    assert ok, why


def _sheen_albedo_head_on(r, n=4000):
    """The directional albedo at normal incidence of MaterialX's sheen lobe (roughness r, not
    squared): D = (2 + 1/r) sin^(1/r)(theta_h) / 2 pi, f = D / (4 (mu_i + mu_o - mu_i mu_o)),
    integrated over the hemisphere by the midpoint rule in theta_i (theta_h = theta_i / 2)."""
    theta = (np.arange(n) + 0.5) * (np.pi / 2) / n
    mu = np.cos(theta)
    d = (2 + 1 / r) * np.sin(theta / 2) ** (1 / r) / (2 * np.pi)
    f = d / (4 * (mu + 1 - mu))
    return float(np.sum(f * mu * np.sin(theta)) * 2 * np.pi * (np.pi / 2) / n)


def test_a_sheen_over_black_reflects_its_lobe_albedo(renderer, stage):
    """A sheen (weight 1, colour (1, 0.5, 0.25), roughness 0.5) over a black base with no
    specular, seen head-on under a dome of radiance 1: colour x the lobe's directional albedo,
    integrated here from MaterialX's formula."""
    colour = np.array([1.0, 0.5, 0.25])
    mat = _surface(stage, "ND_standard_surface_surfaceshader", base=0.0, specular=0.0, sheen=1.0,
                   sheen_color=tuple(colour), sheen_roughness=0.5)
    img = _seen_from_above(renderer, stage, mat, samples=64)
    e = _sheen_albedo_head_on(0.5)
    assert 0.05 < e < 1, e
    ok, why = near(img, e * colour)
    assert ok, why


def _film(renderer, film_ior, thickness=400.0):
    """The mean colour of a black-based smooth specular of IOR 1.5 under a Standard Surface
    thin film of `film_ior` and `thickness` nm, seen head-on under a dome of radiance 1."""
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    mat = _surface(stage, "ND_standard_surface_surfaceshader", base=0.0, specular_roughness=0.0,
                   specular_IOR=1.5, thin_film_thickness=thickness, thin_film_IOR=film_ior)
    return _seen_from_above(renderer, stage, mat)


def test_a_thin_film_of_either_neighbours_index_is_invisible(renderer):
    """A film whose index is the base's (1.5) or the outside's (1) adds no interface: the
    mirror reflects the plain Fresnel F0 = 0.04 at every wavelength, whatever its thickness."""
    for n in (1.5, 1.0):
        ok, why = near(_film(renderer, n), [_f0(1.5)] * 3)
        assert ok, (n, why)


def test_a_thin_film_colours_the_reflection(renderer):
    """A 400 nm film of index 1.33 over glass reflects some wavelengths far more than others:
    the mean colour is far from grey, and another thickness gives another colour."""
    a = _film(renderer, 1.33).reshape(-1, 3).mean(axis=0)
    b = _film(renderer, 1.33, thickness=250.0).reshape(-1, 3).mean(axis=0)
    assert a.max() > 1.3 * a.min(), a
    assert np.abs(a - b).max() > 0.01, (a, b)
