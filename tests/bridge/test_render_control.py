"""Background rendering controlled as a viewer controls it through HdRenderDelegate: a paused
render holds still and, resumed, goes on from where it stopped to the very image an
uninterrupted render makes; a stopped one ends, reports itself converged, ignores executions,
and restarts from its start. The reference is the same scene rendered without interruption."""
import struct
import time

from tide import _tide

W, H = 128, 96


def scene(d):
    assert d.create_sprim("camera", "/Cam")
    d.set("/Cam", "focalLength", 20.0)
    d.set("/Cam", "horizontalAperture", 20.0)
    d.set("/Cam", "verticalAperture", 15.0)
    assert d.create_sprim("renderSettings", "/Render")
    # a few seconds on two cores, its last passes long: paused and stopped part way
    d.set("/Render", "tide:samples", 1024)
    d.set("/Render", "tide:integrator", ("token", "path"))
    assert d.create_sprim("domeLight", "/Dome")
    assert d.create_rprim("sphere", "/Ball")
    d.set_matrix("/Ball", "transform", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -4, 1])
    assert d.create_bprim("renderBuffer", "/Out/color")
    import array
    d.set_array("/Out/color", "dimensions", array.array("i", [W, H]), 1, "i")
    d.set("/Out/color", "format", ("token", "float4"))
    assert d.commit_resources() == []
    p = d.create_render_pass()
    return p


def execute(p):
    p.execute("/Cam", [("color", "/Out/color")], "/Render", hydra=True)


def pixels(d):
    w, h, c, data = d.map_buffer("/Out/color")
    assert (w, h, c) == (W, H, 4)
    return struct.unpack("%df" % (len(data) // 4), data)


def reference(z=None):
    d = _tide.RenderDelegate()
    p = scene(d)
    if z is not None:
        moved(d, z)
    execute(p)
    assert p.wait(120.0) and p.error() is None
    return pixels(d)


def still(p, seconds=0.4):
    """Whether the render's progress holds still for `seconds` (a pass's progress moves by
    whole tiles: a paused one's pixels under way end, and its tiles wait unfinished)."""
    time.sleep(0.02)
    before = p.progress()
    time.sleep(seconds)
    return p.progress() == before


def moved(d, z):
    d.set_matrix("/Ball", "transform", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, 0, z, 1])
    assert d.commit_resources() == []


def test_a_paused_render_holds_still_and_resumes_to_the_uninterrupted_image():
    want = reference()
    d = _tide.RenderDelegate()
    p = scene(d)
    # paused before it starts: the render is prepared and waits before its first pass
    assert d.pause() and d.is_paused()
    execute(p)
    assert not p.wait(0.3) and p.progress() == 0.0 and not p.is_converged()
    assert all(v == 0.0 for v in pixels(d))
    assert d.resume() and not d.is_paused()
    # paused part way, more than once
    paused = 0
    while p.progress() < 0.2:
        time.sleep(0.01)
    for _ in range(3):
        if p.is_converged():
            break
        assert d.pause()
        if not still(p):
            assert p.is_converged(), "a paused render went on"
            break  # its last pixels ended as it was paused
        paused += 1
        assert d.resume()
        time.sleep(0.1)
    assert paused >= 1, "the render ended before it could be paused"
    assert p.wait(120.0) and p.error() is None
    assert pixels(d) == want, "the resumed render differs from one never paused"


def test_a_stopped_render_ignores_executions_until_restarted_from_its_start():
    want = reference(-3.5)
    d = _tide.RenderDelegate()
    p = scene(d)
    execute(p)
    while p.progress() == 0.0:
        time.sleep(0.01)
    assert not p.is_converged()
    assert d.stop() and d.is_stopped()
    assert p.is_converged(), "a stopped render says it will not change"
    frozen = pixels(d)
    execute(p)
    # an edit while stopped: taken, not rendered
    moved(d, -3.5)
    execute(p)
    assert still(p) and pixels(d) == frozen, "an execution while stopped rendered"
    assert d.restart() and not d.is_stopped()
    assert p.wait(120.0) and p.error() is None
    assert pixels(d) == want


def test_a_blocking_stop_returns_with_no_worker_rendering():
    d = _tide.RenderDelegate()
    p = scene(d)
    for blocking in (True, False):
        execute(p)
        while p.progress() == 0.0:
            time.sleep(0.01)
        assert d.stop(blocking=blocking) and d.is_stopped()
        if blocking:
            # the process's CPU time holds still from the moment the stop returns (rendering
            # takes both cores: 0.3 s of it would be ~0.6 s of CPU)
            cpu = time.process_time()
            time.sleep(0.3)
            assert time.process_time() - cpu < 0.03
        assert d.restart()
    assert p.wait(120.0) and p.error() is None
    assert d.stop()
