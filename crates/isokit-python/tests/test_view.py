"""isokit.view: the live viewer window, updated when the script calls it again.

Needs a display (tools/test.sh starts Xvfb); skipped without one unless
ISOKIT_REQUIRE_DISPLAY=1 (CI), where that fails."""

import json
import os
import time

import pytest

import isokit


@pytest.fixture
def display():
    if not os.environ.get("DISPLAY"):
        if os.environ.get("ISOKIT_REQUIRE_DISPLAY") == "1":
            pytest.fail("ISOKIT_REQUIRE_DISPLAY=1 but DISPLAY is not set")
        pytest.skip("no DISPLAY for a window (run under xvfb-run)")


def finals(path):
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        return []
    ev = [json.loads(line) for line in lines if line.endswith("}")]
    return [e for e in ev if e["event"] == "frame" and e["final"]]


def part(r):
    return isokit.sphere(r, center=(-0.6, 0, 0)) | isokit.box((0.4, 0.4, 0.4), center=(0.6, 0, 0))


def test_calling_view_again_updates_the_open_window(display, tmp_path):
    ev, shot = tmp_path / "ev.jsonl", tmp_path / "v.png"
    v = isokit.view(part(0.3), width=96, height=96, backend="cpu", events=ev, screenshot=shot,
                    exit_after_frames=2)
    t0 = time.time()
    while not finals(ev):
        assert v.running, "the viewer exited before its first frame"
        assert time.time() - t0 < 60, "no first frame within 60 s"
        time.sleep(0.02)
    # The same window, a new shape.
    assert isokit.view(part(0.45)) is v
    assert v.wait(60) == 0
    f = finals(ev)
    assert len(f) == 2 and f[1]["reason"] == "edit", f
    # The window's last frame is the new shape, as render draws it.
    expected = tmp_path / "r.png"
    part(0.45).render(width=96, height=96, backend="cpu").save(expected)
    assert shot.read_bytes() == expected.read_bytes()
    v.close()
    assert not os.path.exists(v.path)


def test_view_refuses_what_is_not_a_shape(tmp_path):
    with pytest.raises(TypeError, match="Shape"):
        isokit.Viewer("not a shape")
