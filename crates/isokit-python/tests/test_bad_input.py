"""Bad input gives Python exceptions with the command's messages; nothing crashes the
interpreter. Long calls stop on Ctrl-C and on a progress callback returning False."""

import _thread
import signal
import threading
import time

import numpy as np
import pytest

import isokit
from conftest import icosphere


@pytest.mark.parametrize("points,exc", [
    (np.zeros((4, 2)), ValueError),
    (np.zeros((4,)), TypeError),
    (np.zeros((2, 3, 3)), TypeError),
    (np.zeros((4, 3), dtype=np.int64), TypeError),
    (np.zeros((4, 3), dtype=np.complex128), TypeError),
    ([[0, 0, 0]], TypeError),
    ("points", TypeError),
])
def test_wrong_point_arrays(points, exc):
    with pytest.raises(exc, match="points"):
        isokit.sphere()(points)
    with pytest.raises(exc):
        isokit.sphere().gradient(points)


def test_bad_parameters():
    with pytest.raises(ValueError, match="radius"):
        isokit.sphere(radius=-1)
    with pytest.raises(TypeError, match="parameters are"):
        isokit._isokit._primitive("sphere", {"half": 1.0})
    with pytest.raises(TypeError):
        isokit.sphere(radius=1, size=2)
    with pytest.raises(ValueError, match="finite"):
        isokit.sphere(radius=float("nan"))
    with pytest.raises(ValueError, match="finite"):
        isokit.sphere().offset(float("inf"))
    with pytest.raises(ValueError, match="method"):
        isokit.sphere().sample(method="sparse")
    with pytest.raises(ValueError, match="sign"):
        isokit.mesh("x.obj", sign="parity")
    with pytest.raises(ValueError, match="inside"):
        isokit.volume(np.zeros((3, 3, 3)), inside="left")
    with pytest.raises(ValueError, match="bounds"):
        isokit.sphere().sample(bounds=((1, 1, 1), (0, 0, 0)))
    with pytest.raises(ValueError, match="backend"):
        isokit.sphere().render(backend="tpu")
    with pytest.raises(ValueError, match="image size"):
        isokit.sphere().render(width=0)
    with pytest.raises(ValueError, match="image size"):
        isokit.sphere().render(width=100000, height=100000)
    with pytest.raises(ValueError, match="unbounded"):
        isokit.plane().sample(res=16)


def test_huge_resolutions_are_refused_before_allocating():
    for res in (10**6, 10**5, 3000):
        with pytest.raises(ValueError):
            isokit.sphere().sample(res=res)
        with pytest.raises(ValueError):
            isokit.sphere().mesh(res=res)
    with pytest.raises((ValueError, OverflowError)):
        isokit.sphere().sample(res=-1)
    with pytest.raises(ValueError):
        isokit.sphere().sample(res=1)


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        isokit.mesh(tmp_path / "missing.obj")(np.zeros((1, 3)))
    # Refused when the shape is made, not at its first evaluation.
    with pytest.raises(FileNotFoundError, match="no such file"):
        isokit.mesh(tmp_path / "missing.obj")
    with pytest.raises(FileNotFoundError, match="no such file"):
        isokit.points(tmp_path / "missing.ply")
    with pytest.raises(FileNotFoundError, match="no such file"):
        isokit.volume(tmp_path / "missing.nrrd")
    with pytest.raises(FileNotFoundError):
        isokit.load_scene(tmp_path / "missing.json")
    with pytest.raises(FileNotFoundError):
        isokit.molecule(tmp_path / "missing.pdb")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="bad.obj"):
        isokit.mesh(bad)(np.zeros((1, 3)))
    scene = tmp_path / "bad.json"
    scene.write_text('{"shape": {"union": [{"sphere": {"radius": 1}}, {"cube": {}}]}}')
    with pytest.raises(ValueError, match=r"bad.json: shape.union\[1\].*cube"):
        isokit.load_scene(scene)
    with pytest.raises(ValueError, match="scene format"):
        isokit.load_scene(bad)
    (tmp_path / "v.npy").write_bytes(b"not an npy")
    with pytest.raises(ValueError):
        isokit.volume(tmp_path / "v.npy")(np.zeros((1, 3)))


def test_bad_arrays():
    V, F = icosphere(1)
    P = np.zeros((5, 3))
    with pytest.raises(ValueError, match="no triangles"):
        isokit.signed_distance(V, np.zeros((0, 3), dtype=np.int64), P)
    with pytest.raises(ValueError, match="refers to vertex"):
        isokit.signed_distance(V, F + len(V), P)
    with pytest.raises(ValueError, match="refers to vertex"):
        isokit.signed_distance(V, -F - 1, P)
    with pytest.raises(TypeError, match="integer"):
        isokit.signed_distance(V, F.astype(np.float64), P)
    with pytest.raises(ValueError, match="shape"):
        isokit.signed_distance(V[:, :2], F, P)
    Vn = V.copy()
    Vn[3] = np.nan
    with pytest.raises(ValueError, match="finite"):
        isokit.signed_distance(Vn, F, P)
    with pytest.raises(ValueError, match="finite"):
        isokit.mesh((Vn, F))
    with pytest.raises(ValueError, match="no triangles"):
        isokit.mesh((V, np.zeros((0, 3), dtype=np.int32)))
    with pytest.raises(ValueError, match="no points"):
        isokit.points(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="rows"):
        isokit.points((V, V[:3]))
    with pytest.raises(ValueError, match="NaN"):
        isokit.volume(np.full((3, 3, 3), np.nan))
    with pytest.raises(ValueError, match="3-D"):
        isokit.volume(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="at least 2"):
        isokit.volume(np.zeros((1, 3, 3)))
    assert isokit.signed_distance(V, F, np.zeros((0, 3)))[0].shape == (0,)


def test_progress_callbacks_report_and_cancel():
    s = isokit.torus()
    seen = []
    s.sample(res=96, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert seen and seen[-1][1] == seen[-1][2]
    with pytest.raises(isokit.Cancelled):
        s.sample(res=160, progress=lambda *a: False)

    def boom(*a):
        raise RuntimeError("from the callback")

    with pytest.raises(RuntimeError, match="from the callback"):
        s.mesh(res=160, progress=boom)
    with pytest.raises(TypeError, match="progress"):
        s.sample(res=16, progress=3)


@pytest.fixture
def python_handles_ctrl_c():
    """Python's own SIGINT handler for the test: a process started in the background by a
    shell inherits SIGINT ignored, and then Ctrl-C (and `_thread.interrupt_main`) never
    reaches Python at all."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_ctrl_c_cancels_a_long_call(python_handles_ctrl_c):
    V, F = icosphere(5)
    P = np.random.default_rng(1).uniform(-1.5, 1.5, size=(1_000_000, 3))  # ~20 s of work
    timer = threading.Timer(0.3, _thread.interrupt_main)
    t0 = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        isokit.signed_distance(V, F, P, sign="winding", progress=False)
        time.sleep(10)  # the call was too quick to interrupt: fail below instead
    elapsed = time.perf_counter() - t0
    timer.cancel()
    print(f"stopped {elapsed:.2f} s after the call started (Ctrl-C at 0.3 s)")
    assert elapsed < 5.0, f"took {elapsed:.1f} s to stop"
    # The interpreter and the library are fine afterwards.
    assert isokit.sphere()(np.zeros((1, 3)))[0] == -1.0
