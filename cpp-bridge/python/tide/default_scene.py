"""The scene `tide render` draws when no stage is given: a sunlit pool under a Hošek–Wilkie sky
with its physical sun, exposed by the sunny-16 rule."""

DEFAULT_SCENE_USDA = '''#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
    renderSettingsPrimPath = "/Render/Settings"
    startTimeCode = 1
    endTimeCode = 1
)

def Xform "World"
{
    def Cube "DeckLeft" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (-4, -0.55, 0)
        float3 xformOp:scale = (4, 1, 12)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Stone>
    }

    def Cube "DeckRight" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (4, -0.55, 0)
        float3 xformOp:scale = (4, 1, 12)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Stone>
    }

    def Cube "DeckFront" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -0.55, 4.5)
        float3 xformOp:scale = (4, 1, 3)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Stone>
    }

    def Cube "DeckBack" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -0.55, -4.5)
        float3 xformOp:scale = (4, 1, 3)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Stone>
    }

    def Cube "LawnLeft" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (-2003, -0.56, 0)
        float3 xformOp:scale = (3994, 1, 8000)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Lawn>
    }

    def Cube "LawnRight" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (2003, -0.56, 0)
        float3 xformOp:scale = (3994, 1, 8000)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Lawn>
    }

    def Cube "LawnFront" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -0.56, 2003)
        float3 xformOp:scale = (12, 1, 3994)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Lawn>
    }

    def Cube "LawnBack" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -0.56, -2003)
        float3 xformOp:scale = (12, 1, 3994)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Lawn>
    }

    def Cube "PoolFloor" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -1.55, 0)
        float3 xformOp:scale = (4.2, 0.1, 6.2)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/Tiles>
    }

    def Cube "Water" (prepend apiSchemas = ["MaterialBindingAPI", "TideCausticsAPI"])
    {
        double size = 1
        double3 xformOp:translate = (0, -0.8, 0)
        float3 xformOp:scale = (4, 1.4, 6)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
        rel material:binding = </Looks/PoolWater>
        bool tide:caustics:caster = 1
    }

    def Sphere "Ball" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double radius = 0.3
        double3 xformOp:translate = (1.2, -0.05, 1.5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        rel material:binding = </Looks/Ball>
    }
}

def Scope "Looks"
{
    def Material "Stone"
    {
        token outputs:surface.connect = </Looks/Stone/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.62, 0.58, 0.52)
            float inputs:roughness = 0.8
            token outputs:surface
        }
    }

    def Material "Lawn"
    {
        token outputs:surface.connect = </Looks/Lawn/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.12, 0.2, 0.06)
            float inputs:roughness = 0.9
            token outputs:surface
        }
    }

    def Material "Tiles"
    {
        token outputs:surface.connect = </Looks/Tiles/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.55, 0.8, 0.85)
            float inputs:roughness = 0.4
            token outputs:surface
        }
    }

    def Material "Ball"
    {
        token outputs:surface.connect = </Looks/Ball/Surface.outputs:surface>
        def Shader "Surface"
        {
            uniform token info:id = "UsdPreviewSurface"
            color3f inputs:diffuseColor = (0.8, 0.15, 0.1)
            float inputs:roughness = 0.3
            token outputs:surface
        }
    }

    def Material "PoolWater"
    {
        token outputs:surface.connect = </Looks/PoolWater/Water.outputs:surface>
        token outputs:volume.connect = </Looks/PoolWater/Medium.outputs:volume>
        def Shader "Water"
        {
            uniform token info:id = "TideWater"
            float inputs:ior = 1.333
            float inputs:roughness = 0.02
            token outputs:surface
        }
        def Shader "Medium"
        {
            uniform token info:id = "TideMedium"
            color3f inputs:absorption = (0.45, 0.06, 0.02)
            color3f inputs:scattering = (0.02, 0.03, 0.03)
            token inputs:phase = "hg"
            float inputs:g = 0.9
            token outputs:volume
        }
    }
}

def Scope "Lights"
{
    def DistantLight "Sun" (prepend apiSchemas = ["TideCausticsAPI"])
    {
        float inputs:angle = 0.51
        float3 xformOp:rotateXYZ = (-55, 30, 0)
        uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
        bool tide:caustics:emitter = 1
    }

    def DomeLight "Sky" (prepend apiSchemas = ["TideSkyAPI"])
    {
        uniform token tide:sky:model = "hosekWilkie"
        float tide:sky:turbidity = 3
        color3f tide:sky:groundAlbedo = (0.3, 0.3, 0.3)
        rel tide:sky:sun = </Lights/Sun>
        bool tide:sky:physicalSun = 1
    }
}

def Camera "Camera"
{
    float focalLength = 24
    float horizontalAperture = 36
    float verticalAperture = 20.25
    float2 clippingRange = (0.05, 1000)
    # sunny 16 (f/16, 1/125 s, ISO 100: 10^5 lx maps an 18% grey card to 0.18) with the
    # responsivity 100 pi / 312.5 that makes USD's exposure seed 000's sensor equation
    float exposure:fStop = 16
    float exposure:time = 0.008
    float exposure:iso = 100
    float exposure:responsivity = 1.0053096
    double3 xformOp:translate = (0, 3.2, 8.5)
    float3 xformOp:rotateXYZ = (-16, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}

def Scope "Render"
{
    def RenderSettings "Settings" (prepend apiSchemas = ["TideRenderSettingsAPI"])
    {
        rel camera = </Camera>
        uniform int2 resolution = (640, 360)
        rel products = </Render/Product>
        uniform token tide:integrator = "caustics"
        uniform int tide:samples = 32
    }

    def RenderProduct "Product"
    {
        token productName = "tide.exr"
        rel orderedVars = </Render/Vars/Color>
    }

    def Scope "Vars"
    {
        def RenderVar "Color"
        {
            uniform string sourceName = "color"
        }
    }
}
'''
