"""Edit-to-pixels latency of `isokit view` on the CPU twin, and its orbiting frame rate.

Opens the viewer on a copy of the demo scene (examples/scenes/demo.json: a mesh blended
with a sphere), saves edits to it (a primitive's radius; the mesh's transform; a new node)
and reads, from the viewer's events file, the latency of the first frame each edit
produced (a half-size draft where the finished frame is slow) and of the finished frame
(`latency_ms`: from the file event to the frame presented). The same edits are run
with `--no-reuse` (every edit sampled in full, then every ray traced): the baseline of a full
re-evaluation and re-render, in the same run. "rays reused" is the share of the finished
frame's rays taken from the frame before the edit (the rest were traced). With xdotool, the window is also dragged to
orbit and the camera frames counted.

Needs an X server: DISPLAY, or Xvfb (started here). Standard library only.

    python3 tests/peers/bench_view.py --isokit target/release/isokit [--edits 20] [--size 512]
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def scene(mesh, radius=0.42, dx=0.0, extra=0):
    of = [
        {"transform": {"translate": [dx, 0, 0], "of": {"mesh": {"path": str(mesh), "sign": "auto"}}}},
        {"sphere": {"radius": radius}},
    ]
    of += [{"sphere": {"radius": 0.12, "center": [0.9, 0.55 - 0.2 * i, 0.5]}} for i in range(extra)]
    return {
        "shape": {"smooth_union": {"radius": 0.12, "of": of}},
        "camera": {"eye": [1.6, 1.9, 3.6], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 38},
        "lights": [{"direction": [-0.4, -0.8, -0.6], "intensity": 1.0}],
        "shading": {"mode": "curvature", "color": [0.8, 0.78, 0.75], "ambient": 0.25},
        # Fixed bounds: every version on one lattice (what a user sets to keep samples put).
        "sampling": {"resolution": 112, "bounds": [[-1.35, -1.35, -1.0], [1.45, 1.35, 1.0]]},
    }


def save(path, obj):
    tmp = path.with_suffix(".tmp~")
    tmp.write_text(json.dumps(obj))
    os.replace(tmp, path)


def events(path):
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        return []
    return [json.loads(l) for l in lines if l.endswith("}")]


def finals(ev):
    return [e for e in ev if e.get("event") == "frame" and e.get("final")]


def wait_finals(path, n, timeout=120):
    t0 = time.time()
    while time.time() - t0 < timeout:
        f = finals(events(path))
        if len(f) >= n:
            return f
        time.sleep(0.01)
    raise SystemExit(f"timed out waiting for {n} final frames in {path}")


def edits(kind, n):
    """The n scene versions after the first, for one kind of edit."""
    if kind == "radius":
        return [dict(radius=0.42 + 0.01 * (i % 2 + 1)) for i in range(n)]
    if kind == "mesh transform":
        return [dict(dx=0.02 * (i % 2 + 1)) for i in range(n)]
    return [dict(extra=i % 2 + 1) for i in range(n)]  # a new node, then another


def run(isokit, mesh, kind, n, size, reuse, work):
    path = work / "demo.json"
    ev = work / f"ev-{kind.replace(' ', '_')}-{int(reuse)}.jsonl"
    save(path, scene(mesh))
    args = [isokit, "view", str(path), "--backend", "cpu", "--width", str(size), "--height",
            str(size), "--events", str(ev), "--exit-after-frames", str(n + 1)]
    if not reuse:
        args.append("--no-reuse")
    proc = subprocess.Popen(args, stderr=subprocess.PIPE)
    wait_finals(ev, 1)
    lat, first, evaluated, reused, frame, phases, rays = [], [], [], [], [], [], []
    for i, e in enumerate(edits(kind, n)):
        time.sleep(0.25)
        seen = len([x for x in events(ev) if x.get("event") == "frame"])
        save(path, scene(mesh, **e))
        f = wait_finals(ev, i + 2)[-1]
        new = [x for x in events(ev) if x.get("event") == "frame"][seen:]
        first.append(new[0]["latency_ms"])
        lat.append(f["latency_ms"])
        evaluated.append(f["evaluated_bricks"])
        reused.append(f["reused_bricks"])
        frame.append(f["frame_ms"])
        phases.append([f.get(k, 0.0) for k in ("load_ms", "sample_ms", "prepare_ms")])
        rays.append(100.0 * f.get("reused_rays", 0) / (f["width"] * f["height"]))
    proc.wait(timeout=60)
    return lat, first, evaluated, reused, frame, phases, rays


def orbit(isokit, mesh, size, work, seconds=4.0):
    if not shutil.which("xdotool"):
        return None
    path = work / "orbit.json"
    ev = work / "ev-orbit.jsonl"
    save(path, scene(mesh))
    proc = subprocess.Popen([isokit, "view", str(path), "--backend", "cpu", "--width", str(size),
                             "--height", str(size), "--events", str(ev),
                             "--exit-after-seconds", str(seconds + 6)], stderr=subprocess.PIPE)
    wait_finals(ev, 1)
    wid = subprocess.run(["xdotool", "search", "--name", "isokit view"], capture_output=True,
                         text=True).stdout.split()[0]
    c = size // 2
    subprocess.run(["xdotool", "mousemove", "--window", wid, str(c), str(c), "mousedown", "1"])
    t0 = time.time()
    k = 0
    while time.time() - t0 < seconds:
        k += 1
        subprocess.run(["xdotool", "mousemove", "--window", wid, str(c + (k * 3) % 160), str(c)])
        time.sleep(0.01)
    subprocess.run(["xdotool", "mouseup", "1"])
    proc.wait(timeout=60)
    cam = [e for e in events(ev) if e.get("reason") == "camera"]
    drafts = [e for e in cam if not e["final"]]
    return len(drafts) / seconds, statistics.median([e["frame_ms"] for e in drafts] or [0]), len(cam)


def p95(x):
    x = sorted(x)
    return x[min(len(x) - 1, int(round(0.95 * (len(x) - 1))))]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--isokit", default=str(ROOT / "target/release/isokit"))
    ap.add_argument("--edits", type=int, default=20)
    ap.add_argument("--size", type=int, default=512)
    a = ap.parse_args()
    xvfb = None
    if not os.environ.get("DISPLAY"):
        xvfb = subprocess.Popen(["Xvfb", ":97", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                                stderr=subprocess.DEVNULL)
        os.environ["DISPLAY"] = ":97"
        time.sleep(1)
    mesh = ROOT / "data/trefoil.ply"
    rows = []
    try:
        with tempfile.TemporaryDirectory() as d:
            work = Path(d)
            for kind in ["radius", "mesh transform", "new node"]:
                for reuse in [True, False]:
                    lat, fi, ev, re, fr, ph, ry = run(a.isokit, mesh, kind, a.edits, a.size, reuse,
                                                  work)
                    rows.append((kind, "reuse" if reuse else "full (--no-reuse)",
                                 statistics.median(fi), p95(fi),
                                 statistics.median(lat), p95(lat), statistics.median(ev),
                                 statistics.median(re), statistics.median(ry),
                                 statistics.median(fr),
                                 *[statistics.median(p[i] for p in ph) for i in range(3)]))
            orb = orbit(a.isokit, mesh, a.size, work)
    finally:
        if xvfb:
            xvfb.terminate()
    print(f"| edit ({a.edits} each, {a.size}², CPU) | sampling | first frame median ms | p95 ms "
          "| finished frame median ms | p95 ms | bricks evaluated | reused | rays reused % "
          "| frame ms | load ms | sample ms | prepare ms |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | " + " | ".join(f"{x:.0f}" for x in r[2:]) + " |")
    if orb:
        print(f"\norbiting: {orb[0]:.1f} draft frames/s (half size, median {orb[1]:.0f} ms per "
              f"frame), {orb[2]} camera frames")


if __name__ == "__main__":
    main()
