"""The tideSchemas plugin: usd-core knows every schema of the contract, and Sdr resolves the
TideWater and TideMedium shader nodes with the contract's inputs, types and defaults."""
import os
import subprocess
import sys

import pytest
from pxr import Gf, Sdr, Usd, UsdGeom

from conftest import ROOT

API_SCHEMAS = {
    "TideCausticsAPI": {"tide:caustics:emitter": False, "tide:caustics:caster": False,
                        "tide:caustics:receiver": True, "tide:caustics:transparency": "off"},
    "TideBlobbyAPI": {"tide:blobby:threshold": 0.5},
    "TideSubdivisionAPI": {"tide:subdivision:level": 0},
    "TideBubbleAPI": {},
    "TideDropletsAPI": {"tide:droplets:asVolume": False},
    "TideSkyAPI": {"tide:sky:model": "hosekWilkie", "tide:sky:turbidity": 3.0,
                   "tide:sky:groundAlbedo": Gf.Vec3f(0.3, 0.3, 0.3),
                   "tide:sky:physicalSun": False},
    "TideWetAPI": {"tide:wet:amount": 0.0, "tide:wet:ior": 1.333, "tide:wet:waterCompliant": True},
    "TideCameraAPI": {"tide:camera:filter": "none"},
    "TideRenderSettingsAPI": {"tide:integrator": "caustics", "tide:samples": 64,
                              "tide:maxDepth": 64, "tide:adaptive:threshold": 0.0,
                              "tide:seed": 0, "tide:time:budget": 0.0,
                              "tide:adaptive:minSamples": 0, "tide:pixelFilter": "box",
                              "tide:pixelFilter:width": 0.0},
}

# Contract section 3, typed independently of the plugin files.
TIDE_WATER = {"ior": 1.333, "dispersion": False, "temperature": 20.0, "salinity": 0.0,
              "roughness": 0.0, "surfaceModel": "dielectric", "windSpeed": 5.0,
              "windDirection": 0.0, "priority": 0, "medium": ""}
TIDE_MEDIUM = {"jerlovType": "", "jerlovSource": "williamson2022", "absorption": (0, 0, 0),
               "scattering": (0, 0, 0), "densityScale": 1.0, "phase": "hg", "g": 0.0,
               "g2": -0.3, "lobeMix": 0.9, "molecularWeight": 0.0, "chlorophyll": 0.0,
               "cdom": 0.0, "spm": 0.0, "profileDepth": 0.0, "profileWidth": 0.0,
               "profilePeak": 0.0, "method": "volumetric"}
TYPES = {"ior": "float", "dispersion": "bool", "surfaceModel": "token", "priority": "int",
         "absorption": "color3f", "jerlovType": "token", "phase": "token",
         "method": "token", "medium": "token"}


def _close(a, b):
    if isinstance(b, tuple):
        return all(abs(x - y) < 1e-6 for x, y in zip(a, b))
    if isinstance(b, float):
        # defaults are stored as 32-bit floats: 1e-6 relative is float32 precision
        return abs(a - b) <= 1e-6 * max(1.0, abs(b))
    return a == b


@pytest.mark.parametrize("name", sorted(API_SCHEMAS))
def test_api_schema_registered_with_fallbacks(name):
    reg = Usd.SchemaRegistry()
    assert reg.IsAppliedAPISchema(name)
    stage = Usd.Stage.CreateInMemory()
    target = "RenderSettings" if name == "TideRenderSettingsAPI" else "Xform"
    prim = stage.DefinePrim("/P", target)
    prim.ApplyAPI(name)
    assert prim.HasAPI(name)
    for attr, value in API_SCHEMAS[name].items():
        got = prim.GetAttribute(attr).Get()
        assert _close(got, value), (attr, got, value)


def test_relationships_declared():
    reg = Usd.SchemaRegistry()
    assert "tide:sky:sun" in reg.FindAppliedAPIPrimDefinition("TideSkyAPI").GetPropertyNames()
    assert "tide:medium" in reg.FindAppliedAPIPrimDefinition("TideCameraAPI").GetPropertyNames()


def test_ocean_is_a_gprim_with_contract_defaults():
    stage = Usd.Stage.CreateInMemory()
    prim = stage.DefinePrim("/Ocean", "TideOcean")
    assert prim.IsA(UsdGeom.Gprim)
    expect = {"windSpeed": 5.0, "windDirection": 0.0, "spectrum": "piersonMoskowitz",
              "patchSize": 64.0, "resolution": 256, "choppiness": 0.0, "seed": 0,
              "extent": 1000.0, "depth": 0.0}
    for attr, value in expect.items():
        assert _close(prim.GetAttribute(attr).Get(), value), attr
    assert prim.GetAttribute("time").Get() is None
    assert UsdGeom.Imageable(prim).ComputeVisibility() == "inherited"


@pytest.mark.parametrize("ident,table", [("TideWater", TIDE_WATER), ("TideMedium", TIDE_MEDIUM)])
def test_sdr_resolves_shader(ident, table):
    node = Sdr.Registry().GetShaderNodeByIdentifier(ident)
    assert node is not None and node.IsValid()
    assert sorted(node.GetShaderInputNames()) == sorted(table)
    for name, value in table.items():
        inp = node.GetShaderInput(name)
        assert _close(inp.GetDefaultValue(), value), (name, inp.GetDefaultValue())
        if name in TYPES:
            assert str(inp.GetTypeAsSdfType().GetSdfType()) == TYPES[name], name
    assert list(node.GetShaderOutputNames()) == (["surface"] if ident == "TideWater"
                                                 else ["volume"])


def test_discovered_through_environment_alone():
    """A fresh usd-core process with only the launcher's variables finds everything."""
    code = ("from pxr import Sdr, Usd;"
            "assert Usd.SchemaRegistry().IsAppliedAPISchema('TideCausticsAPI');"
            "n = Sdr.Registry().GetShaderNodeByIdentifier('TideWater');"
            "assert n and 'ior' in n.GetShaderInputNames(), n;"
            "print('ok')")
    envv = dict(os.environ)
    envv.update(PXR_PLUGINPATH_NAME=os.path.join(ROOT, "schemas"),
                PXR_SDR_FS_PLUGIN_SEARCH_PATHS=os.path.join(ROOT, "schemas", "shaders"),
                PXR_SDR_FS_PLUGIN_ALLOWED_EXTS="usda", TF_ENV_SETTING_ALERTS_ENABLED="0")
    envv.pop("PYTHONPATH", None)
    out = subprocess.run([sys.executable, "-c", code], env=envv, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_shade_resolves_shader_prim():
    stage = Usd.Stage.CreateInMemory()
    from pxr import UsdShade
    sh = UsdShade.Shader.Define(stage, "/M/Water")
    sh.CreateIdAttr("TideWater")
    node = Sdr.Registry().GetShaderNodeByIdentifier(sh.GetShaderId())
    assert node.GetShaderInput("ior").GetDefaultValue() == pytest.approx(1.333, rel=1e-6)


def test_generated_schema_is_up_to_date(tmp_path):
    """generatedSchema.usda and plugInfo.json are what generate.py makes from schema.usda."""
    schemas = os.path.join(ROOT, "schemas")
    before = {f: open(os.path.join(schemas, f)).read()
              for f in ("generatedSchema.usda", "plugInfo.json")}
    copy = tmp_path / "schemas"
    copy.mkdir()
    for f in ("schema.usda", "generate.py"):
        (copy / f).write_text(open(os.path.join(schemas, f)).read())
    subprocess.run([sys.executable, str(copy / "generate.py")], check=True)
    for f, text in before.items():
        assert (copy / f).read_text() == text, f
