"""isokit.view: the live viewer window, updated when the script calls it again.

Needs a display (tools/test.sh starts Xvfb); skipped without one unless
ISOKIT_REQUIRE_DISPLAY=1 (CI), where that fails."""

import json
import os
import struct
import sys
import time
import zlib

import numpy as np

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


def read_png(path):
    """An 8-bit RGBA PNG as an (h, w, 4) array (the writer's format; all five filters)."""
    data = path.read_bytes()
    pos, idat, (w, h) = 8, b"", (0, 0)
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h = struct.unpack(">II", body[:8])
            assert body[8:10] == bytes([8, 6]), "8-bit RGBA"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride = zlib.decompress(idat), 4 * w
    out = np.zeros((h, stride), np.int32)
    for y in range(h):
        f, row = raw[y * (stride + 1)], np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1)
        prev = out[y - 1] if y else np.zeros(stride, np.int32)
        cur = row.astype(np.int32)
        if f == 0:
            out[y] = cur
        elif f == 2:
            out[y] = (cur + prev) & 255
        else:
            line = np.zeros(stride, np.int32)
            for x in range(stride):
                a = line[x - 4] if x >= 4 else 0
                b, c = prev[x], prev[x - 4] if x >= 4 else 0
                if f == 1:
                    p = a
                elif f == 3:
                    p = (a + b) // 2
                else:
                    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                    p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (cur[x] + p) & 255
            out[y] = line
    return out.reshape(h, w, 4)


def part(r):
    # The bore changes, the bounds (the box's) do not: the window keeps its camera across
    # edits, and a fresh render of the edited part frames the same bounds.
    return isokit.box((0.8, 0.4, 0.4)) - isokit.sphere(r, center=(0.8, 0.4, 0))


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
    # The window's last frame is the new shape, as render draws it (the window keeps the
    # first version's lattice while the shape fits it: equal to 1/255 on average, not bit
    # for bit), and not the old one.
    new, old = tmp_path / "new.png", tmp_path / "old.png"
    part(0.45).render(width=96, height=96, backend="cpu").save(new)
    part(0.3).render(width=96, height=96, backend="cpu").save(old)
    got = read_png(shot)
    to_new = np.abs(got - read_png(new)).mean()
    to_old = np.abs(got - read_png(old)).mean()
    assert to_new <= 1.0, to_new
    assert to_old > 4 * to_new, (to_old, to_new)
    # The child removed the scene's folder when its window closed.
    assert not os.path.exists(os.path.dirname(v.path))
    v.close()
    assert not os.path.exists(v.path)


def test_view_refuses_what_is_not_a_shape(tmp_path):
    with pytest.raises(TypeError, match="Shape"):
        isokit.Viewer("not a shape")


def test_view_without_a_display_raises_at_once(monkeypatch):
    if not sys.platform.startswith("linux"):
        pytest.skip("the display variables are Linux's")
    for k in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(k, raising=False)
    with pytest.raises(OSError, match="no display"):
        isokit.Viewer(part(0.3))
