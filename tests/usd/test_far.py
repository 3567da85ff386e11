"""Scenes far from the world's origin: moving a whole scene, its camera and its lights with it,
changes nothing the camera sees. Georeferenced layouts and sets built kilometres from the
origin put world translations of 10^5-10^6 units on small objects; single precision cannot
hold such positions finer than 10^-2-10^-1 units, so the renderer must take them relative to
a point near the camera in double precision.

Each test renders the same content under a /World transform at the origin and far from it,
with the same seed: images equal within a small fraction of their mean (the few paths whose
float rounding differs decorrelate), where single-precision world positions miss by tens of
percent (a 4 cm ball 10^5 units out is cut into slabs)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from conftest import bind, camera, exact_lambert_material, render, settings, shader_node
from test_ocean import ocean_prim, sea_material, sun_and_sky

# not multiples of anything: the camera lands anywhere within the cell it is placed about
FAR = [(1.0e5 + 0.37, 0.0, -2.0e5 + 0.11), (2.0e6 + 0.61, 3.0e4 + 0.2, 1.0e6 - 0.43)]
MACRO = (39062 * 256.0 + 120.3, 120.2, -39062 * 256.0 + 120.1)
W = H = 48


def _world(stage, offset):
    world = UsdGeom.Xform.Define(stage, "/World")
    if any(offset):
        world.AddTranslateOp().Set(Gf.Vec3d(*offset))
    return world


def _table_top(stage, offset, scale=1.0):
    """A 4 cm ball, a 2 cm box moving over the shutter and a PointInstancer of three 1 cm
    balls with velocities, each 1 mm over a grey ground (not touching it: where surfaces
    touch, a rounding decides what a ray meets), lit by a spotlight, a small rect light and the
    sun, seen from 30 cm. With `scale`, everything but the sun is that much smaller (the set
    under a scale, the camera nearer and its near clipping distance with it): the same image,
    as light and geometry scale alike."""
    _world(stage, offset)
    cam = camera(stage, path="/World/Cam", pos=(0, 0.1 * scale, 0.3 * scale), focal=50.0,
                 aperture=(10.0, 10.0))
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.01 * scale, 10000))
    cam.AddRotateXOp().Set(-18.0)
    root = UsdGeom.Xform.Define(stage, "/World/Set")
    if scale != 1.0:
        root.AddScaleOp().Set(Gf.Vec3f(scale, scale, scale))
    cam.GetShutterOpenAttr().Set(-0.25)
    cam.GetShutterCloseAttr().Set(0.25)
    grey = exact_lambert_material(stage, "/Looks/Grey", 0.5)
    ground = UsdGeom.Mesh.Define(stage, "/World/Set/Ground")
    ground.CreatePointsAttr([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ball = UsdGeom.Sphere.Define(stage, "/World/Set/Ball")
    ball.CreateRadiusAttr(0.02)
    ball.AddTranslateOp().Set(Gf.Vec3d(0, 0.021, 0))
    box = UsdGeom.Cube.Define(stage, "/World/Set/Box")
    box.CreateSizeAttr(0.02)
    op = box.AddTranslateOp()
    op.Set(Gf.Vec3d(-0.04, 0.011, 0.03), 0.0)
    op.Set(Gf.Vec3d(-0.02, 0.011, 0.03), 1.0)
    inst = UsdGeom.PointInstancer.Define(stage, "/World/Set/Beads")
    proto = UsdGeom.Sphere.Define(stage, "/World/Set/Beads/Protos/Bead")
    proto.CreateRadiusAttr(0.005)
    inst.CreatePrototypesRel().SetTargets([proto.GetPath()])
    inst.CreateProtoIndicesAttr([0, 0, 0])
    inst.CreatePositionsAttr([(0.04, 0.006, 0.0), (0.05, 0.006, 0.02), (0.03, 0.006, 0.04)])
    inst.CreateVelocitiesAttr([(0, 0, 0.02), (0.02, 0, 0), (0, 0.01, 0)])
    for p in ("/World/Set/Ground", "/World/Set/Ball", "/World/Set/Box", "/World/Set/Beads"):
        bind(stage.GetPrimAtPath(p), grey)
    spot = UsdLux.SphereLight.Define(stage, "/World/Set/Spot")
    spot.CreateRadiusAttr(0.01)
    spot.CreateIntensityAttr(40.0)
    spot.AddTranslateOp().Set(Gf.Vec3d(0.02, 0.3, 0.05))
    spot.AddRotateXOp().Set(-90.0)
    shaping = UsdLux.ShapingAPI.Apply(spot.GetPrim())
    shaping.CreateShapingConeAngleAttr(20.0)
    shaping.CreateShapingConeSoftnessAttr(0.2)
    rect = UsdLux.RectLight.Define(stage, "/World/Set/Panel")
    rect.CreateWidthAttr(0.05)
    rect.CreateHeightAttr(0.05)
    rect.CreateIntensityAttr(30.0)
    rect.AddTranslateOp().Set(Gf.Vec3d(-0.1, 0.1, 0.05))
    rect.AddRotateYOp().Set(-60.0)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(1.5)
    sun.AddRotateXOp().Set(-60.0)
    settings(stage, cam="/World/Cam", res=(W, H), samples=16, integrator="path", maxDepth=3,
             vars_=("color", "depth"))


def _same(far, near):
    """The images differ by under 0.5 % of the near one's mean, pixel differences averaged
    (renders 10^5-10^6 units out with single-precision world positions: 24-28 %, or no image)."""
    diff = np.abs(far.astype(np.float64) - near).mean()
    return diff < 5e-3 * near.mean(), (diff, near.mean())


def _same_depth(far, near):
    """Camera distances differ by under 10^-4 of themselves on average over the pixels that
    see something (the first hit, which no path's randomness decorrelates; 10^-2 with
    single-precision world positions)."""
    far, near = far[..., 0].astype(np.float64), near[..., 0].astype(np.float64)
    seen = near < 1e3
    assert seen.any() and np.array_equal(seen, far < 1e3), "the same pixels see something"
    rel = np.abs(far[seen] - near[seen]) / near[seen]
    return rel.mean() < 1e-4, rel.mean()


_NEAR = {}


def _near(renderer, build):
    """The render of `build` at the origin (once per module)."""
    if build not in _NEAR:
        s = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(s, UsdGeom.Tokens.y)
        build(s, (0.0, 0.0, 0.0))
        _NEAR[build] = render(renderer, s)
    return _NEAR[build]


@pytest.mark.parametrize("offset, scale", [(FAR[0], 1.0), (FAR[1], 1.0), (MACRO, 1 / 25)])
def test_a_table_top_far_out_renders_as_at_the_origin(renderer, stage, offset, scale):
    """Also 25 times smaller (a 1.6 mm ball seen from 1.2 cm, near clipping at 0.4 mm) 10^7
    units out with the camera 120 units from the nearest multiple of 256: 5-10 % off when the
    origin snapped to 256-unit cells whatever the camera's near distance."""
    _table_top(stage, offset, scale)
    problems = []
    far = render(renderer, stage, problems)
    assert problems == [], problems
    near = _near(renderer, _table_top)
    assert near["color"][..., :3].mean() > 0.01, "the scene is lit"
    ok, why = _same(far["color"][..., :3], near["color"][..., :3])
    assert ok, why
    ok, why = _same_depth(far["depth"] / scale, near["depth"])
    assert ok, why


def _sea(stage, offset):
    """An open sea (TideOcean, 16 m patches) under the sun and its sky, seen from 3 m up."""
    _world(stage, offset)
    cam = camera(stage, path="/World/Cam", pos=(0, 3, 0), focal=35.0, aperture=(36.0, 24.0))
    cam.AddRotateXOp().Set(-12.0)
    ocean = ocean_prim(stage, "/World/Ocean", windSpeed=6.0, patchSize=16.0, resolution=64,
                       choppiness=0.5, extent=200.0)
    sea_material(stage, ocean)
    sun_and_sky(stage, 30.0)
    settings(stage, cam="/World/Cam", res=(W, 32), samples=8, integrator="path", maxDepth=4,
             vars_=("color", "depth"))


@pytest.mark.parametrize("offset", FAR[:1])
def test_an_ocean_far_out_renders_as_at_the_origin(renderer, stage, offset):
    near = _near(renderer, _sea)
    _sea(stage, offset)
    far = render(renderer, stage)
    sea = near["depth"][..., 0] < 1e3
    assert 0.3 < sea.mean() < 0.9, "the sea and the sky are both in view"
    ok, why = _same(far["color"][..., :3], near["color"][..., :3])
    assert ok, why
    ok, why = _same_depth(far["depth"], near["depth"])
    assert ok, why


def _split_by_x(stage, space, x0):
    """A MaterialX material, red where the `space` position's x is past x0, green before."""
    mat = UsdShade.Material.Define(stage, "/Looks/Split")
    node = lambda name, node_id, **inputs: shader_node(stage, "/Looks/Split/" + name, node_id, **inputs)
    p = node("P", "ND_position_vector3", space=space).CreateOutput("out", Sdf.ValueTypeNames.Float3)
    x = node("X", "ND_extract_vector3", **{"in": p}).CreateOutput("out", Sdf.ValueTypeNames.Float)
    colour = node("Side", "ND_ifgreater_color3", value1=x, value2=x0, in1=(0.8, 0.0, 0.0),
                  in2=(0.0, 0.8, 0.0)).CreateOutput("out", Sdf.ValueTypeNames.Color3f)
    surf = node("SR", "ND_standard_surface_surfaceshader", base=1.0, base_color=colour,
                specular=0.0)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(surf.CreateOutput("out", Sdf.ValueTypeNames.Token))
    return mat


def test_world_space_shading_reads_the_world_position_far_out(renderer, stage):
    """A panel 10^5 units out coloured by its world x (green left of x0, red right of it)
    through MaterialX's world-space position: the halves keep their colours, as at the
    origin, so what shading reads as the world position is still the world's."""
    x0, z0 = FAR[0][0], FAR[0][2]
    _world(stage, FAR[0])
    cam = camera(stage, path="/World/Cam", pos=(0, 5, 0), aperture=(40.0, 40.0),
                 projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr(Gf.Vec3f(1, 1, 1))
    panel = UsdGeom.Mesh.Define(stage, "/World/Panel")
    panel.CreatePointsAttr([(-2, 0, -2), (-2, 0, 2), (2, 0, 2), (2, 0, -2)])
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(panel.GetPrim(), _split_by_x(stage, "world", x0))
    settings(stage, cam="/World/Cam", res=(32, 32), samples=4, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3].astype(np.float64)
    assert [q for q in problems if q.prim.startswith("/Looks")] == [], problems
    assert z0 != 0
    left, right = img[:, :12].mean(axis=(0, 1)), img[:, -12:].mean(axis=(0, 1))
    assert left[1] > 0.5 and left[0] < 0.05, left
    assert right[0] > 0.5 and right[1] < 0.05, right


# Geometry authored far out in its own space: sets exported with their points in world
# coordinates, or brought back by a transform, keep those numbers in the geometry itself. Rays
# must still meet it as they meet the same geometry authored about its origin.
T = 1.0e4 + 0.37
_ROOM = [(x, y, z) for y in (0.0, 4.0) for z in (-2.0, 2.0) for x in (-2.0, 2.0)]
# inward-facing walls; each is four triangles about its centre (edges shared by triangles
# of one wall and by walls)
_WALLS = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]


def _room_mesh(stage, path, shift):
    points = [(x + shift, y, z) for x, y, z in _ROOM]
    indices = []
    for wall in _WALLS:
        c = np.mean([_ROOM[i] for i in wall], axis=0)
        points.append((c[0] + shift, c[1], c[2]))
        for a in range(4):
            indices += [wall[a], wall[(a + 1) % 4], len(points) - 1]
    room = UsdGeom.Mesh.Define(stage, path)
    room.CreatePointsAttr(points)
    room.CreateFaceVertexCountsAttr([3] * (len(indices) // 3))
    room.CreateFaceVertexIndicesAttr(indices)
    return room


@pytest.mark.parametrize("how", ["points", "prototype"])
def test_a_closed_room_authored_far_out_in_its_own_space_lets_no_light_in(renderer, stage, how):
    """A closed room of zero-thickness walls, its points 10^4 units out along x and brought
    back by the prim's transform (or a PointInstancer's instance of it), the camera inside and
    the sun and a dome outside: no light gets in, every pixel is black (2-100 of 2304 pixels
    lit along the edges while rays met the room in its own far-out numbers). Walls meet at
    shared vertices, so nothing but rounding could let light through."""
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    grey = exact_lambert_material(stage, "/Looks/Grey", 0.8)
    if how == "points":
        room = _room_mesh(stage, "/Room", T)
        room.AddTranslateOp().Set(Gf.Vec3d(-T, 0, 0))
        bind(room.GetPrim(), grey)
    else:
        inst = UsdGeom.PointInstancer.Define(stage, "/Rooms")
        room = _room_mesh(stage, "/Rooms/Protos/Room", T)
        bind(room.GetPrim(), grey)
        inst.CreatePrototypesRel().SetTargets([room.GetPath()])
        inst.CreateProtoIndicesAttr([0])
        inst.CreatePositionsAttr([(-T, 0.0, 0.0)])
    views = [((0.5, 1.0, 1.5), -20.0, -35.0, 12.0), ((-1.9, 3.9, 1.9), 60.0, 140.0, 10.0)]
    for k, (pos, down, turn, focal) in enumerate(views):
        cam = camera(stage, path="/Cam%d" % k, pos=pos, focal=focal)
        cam.AddRotateYOp().Set(turn)
        cam.AddRotateXOp().Set(down)
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(50.0)
    sun.AddRotateYOp().Set(30.0)
    sun.AddRotateXOp().Set(-40.0)
    UsdLux.DomeLight.Define(stage, "/Sky").CreateIntensityAttr(20.0)
    for k in range(len(views)):
        settings(stage, path="/Render/S%d" % k, cam="/Cam%d" % k, res=(48, 48), samples=32,
                 integrator="path", maxDepth=8)
    for k in range(len(views)):
        problems = []
        img = render(renderer, stage, problems, settings="/Render/S%d" % k)["color"][..., :3]
        assert problems == [], problems
        lit = int((img.max(axis=2) > 0).sum())
        assert lit == 0, "view %d: %d of %d pixels lit" % (k, lit, img.shape[0] * img.shape[1])


def test_object_space_shading_reads_the_authored_position_far_out(renderer, stage):
    """A panel and two balls (a points prim) whose points are 10^4 units out in their own
    space, brought back by their transforms, coloured by MaterialX's object-space position
    (red where x is past the authored centre T, green before it): the halves keep their
    colours, so shading reads the points as authored, whatever the renderer does with the
    numbers."""
    cam = camera(stage, pos=(0, 5, 0), aperture=(40.0, 40.0), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    UsdLux.DomeLight.Define(stage, "/Dome").CreateColorAttr(Gf.Vec3f(1, 1, 1))
    panel = UsdGeom.Mesh.Define(stage, "/Panel")
    panel.CreatePointsAttr([(T - 2, 0, -2), (T - 2, 0, 0), (T + 2, 0, 0), (T + 2, 0, -2)])
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    panel.AddTranslateOp().Set(Gf.Vec3d(-T, 0, 0))
    balls = UsdGeom.Points.Define(stage, "/Balls")
    balls.CreatePointsAttr([(T - 1, 0, 1), (T + 1, 0, 1)])
    balls.CreateWidthsAttr([1.6, 1.6])
    balls.AddTranslateOp().Set(Gf.Vec3d(-T, 0, 0))
    mat = _split_by_x(stage, "object", T)
    bind(panel.GetPrim(), mat)
    bind(balls.GetPrim(), mat)
    settings(stage, res=(32, 32), samples=4, integrator="path", maxDepth=1)
    problems = []
    img = render(renderer, stage, problems)["color"][..., :3].astype(np.float64)
    assert [q for q in problems if q.prim.startswith("/Looks")] == [], problems
    # image rows run from -z (top) to +z: the panel above, the balls below
    for part, rows in (("panel", slice(4, 12)), ("balls", slice(20, 26))):
        left, right = img[rows, 6:12].mean(axis=(0, 1)), img[rows, -12:-6].mean(axis=(0, 1))
        assert left[1] > 0.5 and left[0] < 0.05, (part, left)
        assert right[0] > 0.5 and right[1] < 0.05, (part, right)


def test_displacement_reads_the_authored_position_far_out(renderer, stage):
    """A grid of quads 10^4 units out in its own space, brought back by its transform,
    displaced by MaterialX along its normal by 1 where its object-space x is past the authored
    centre T (0 before it), seen from 5 above: the depth reads 4 on the right and 5 on the
    left, as authored, whatever the renderer does with the numbers."""
    cam = camera(stage, pos=(0, 5, 0), aperture=(40.0, 40.0), projection="orthographic")
    cam.AddRotateXOp().Set(-90.0)
    UsdLux.DomeLight.Define(stage, "/Dome")
    grid = UsdGeom.Mesh.Define(stage, "/Grid")
    xs = np.linspace(-2, 2, 9)
    grid.CreatePointsAttr([(T + x, 0, z) for z in xs for x in xs])
    grid.CreateFaceVertexCountsAttr([4] * 64)
    grid.CreateFaceVertexIndicesAttr([k for j in range(8) for i in range(8)
                                      for k in (9 * j + i, 9 * j + i + 9, 9 * j + i + 10, 9 * j + i + 1)])
    grid.CreateSubdivisionSchemeAttr("none")
    grid.AddTranslateOp().Set(Gf.Vec3d(-T, 0, 0))
    mat = UsdShade.Material.Define(stage, "/Looks/Step")
    node = lambda name, node_id, **inputs: shader_node(stage, "/Looks/Step/" + name, node_id, **inputs)
    p = node("P", "ND_position_vector3", space="object").CreateOutput("out", Sdf.ValueTypeNames.Float3)
    x = node("X", "ND_extract_vector3", **{"in": p}).CreateOutput("out", Sdf.ValueTypeNames.Float)
    # past T + 0.25: the vertex column at T (and the grid's triangles leaning over it) stays down
    step = node("Step", "ND_ifgreater_float", value1=x, value2=T + 0.25, in1=1.0,
                in2=0.0).CreateOutput("out", Sdf.ValueTypeNames.Float)
    d = node("D", "ND_displacement_float", displacement=step, scale=1.0)
    surf = node("SR", "ND_standard_surface_surfaceshader", base=1.0, specular=0.0)
    mat.CreateSurfaceOutput("mtlx").ConnectToSource(surf.CreateOutput("out", Sdf.ValueTypeNames.Token))
    mat.CreateDisplacementOutput("mtlx").ConnectToSource(d.CreateOutput("out", Sdf.ValueTypeNames.Token))
    bind(grid.GetPrim(), mat)
    settings(stage, res=(32, 32), samples=1, integrator="path", maxDepth=1, vars_=("depth",))
    problems = []
    depth = render(renderer, stage, problems)["depth"][..., 0].astype(np.float64)
    assert [q for q in problems if q.prim.startswith("/Looks")] == [], problems
    assert np.allclose(depth[4:28, 2:14], 5.0, atol=1e-3), depth[4:28, 2:14]
    assert np.allclose(depth[4:28, 20:30], 4.0, atol=1e-3), depth[4:28, 20:30]
