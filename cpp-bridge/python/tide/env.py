"""Environment for usd-core: makes Tide's schema plugin and shader definitions visible.

`prepare()` must run before the first `import pxr` of the process to take effect through
environment variables (the `./tide` launcher sets the same ones); `register_shaders()` works
afterwards as well, registering TideWater/TideMedium with Sdr directly if the filesystem
discovery did not find them.
"""
import os

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
SCHEMAS = os.path.join(REPO, "schemas")
SHADERS = os.path.join(SCHEMAS, "shaders")
SHADER_IDS = ("TideWater", "TideMedium")


def _prepend(var, value):
    cur = os.environ.get(var, "")
    parts = [p for p in cur.split(os.pathsep) if p]
    if value not in parts:
        os.environ[var] = os.pathsep.join([value] + parts)


def prepare():
    """Puts schemas/ on PXR_PLUGINPATH_NAME and shaders/ on the Sdr filesystem search path."""
    _prepend("PXR_PLUGINPATH_NAME", SCHEMAS)
    _prepend("PXR_SDR_FS_PLUGIN_SEARCH_PATHS", SHADERS)
    exts = [e for e in os.environ.get("PXR_SDR_FS_PLUGIN_ALLOWED_EXTS", "").split(":") if e]
    if "usda" not in exts:
        os.environ["PXR_SDR_FS_PLUGIN_ALLOWED_EXTS"] = ":".join(exts + ["usda"])
    os.environ.setdefault("TF_ENV_SETTING_ALERTS_ENABLED", "0")


def register_shaders():
    """Makes sure Sdr resolves TideWater and TideMedium; returns the ids it had to add."""
    from pxr import Sdr, Usd, UsdShade

    reg = Sdr.Registry()
    added = []
    for ident in SHADER_IDS:
        if reg.GetShaderNodeByIdentifier(ident):
            continue
        path = os.path.join(SHADERS, ident + ".usda")
        stage = Usd.Stage.Open(path)
        shader = UsdShade.Shader(stage.GetPrimAtPath("/" + ident))
        for result in UsdShade.ShaderDefUtils.GetDiscoveryResults(shader, path):
            reg.AddDiscoveryResult(result)
        added.append(ident)
    return added


def load_module(fake=None):
    """The bridge module `tide._tide`, or the recording fake when TIDE_FAKE=1 (or fake=True)."""
    if fake is None:
        fake = os.environ.get("TIDE_FAKE", "") not in ("", "0")
    if fake:
        from tide import fake as module
        return module
    try:
        from tide import _tide as module
    except ImportError as e:
        raise RuntimeError(
            "the Tide module tide._tide is not built (%s); run `bash scripts/setup.sh`" % e) from e
    return module
