"""Band fields on Dask: throughput with 1 and 2 worker processes against the single-process
sampling, the cost per block (chunk sizes), and each worker's peak memory at a 1024³ band.

The demo scene (examples/scenes/demo.json: a 1,440-triangle trefoil mesh blended with a
sphere) is sampled in one process by `shape.sample` and written as the same store by
zarr-python (the baseline, on 1 and on 2 threads), and by `isokit.dask.sample` +
`isokit.dask.to_zarr` on a LocalCluster (worker processes of one Dask thread each, the
sampler on 1 thread per worker, or on all cores), all in one run. Every Dask store is
compared bit for bit with `isokit scene -o field.zarr`'s. Worker memory is the worker's own
report: the largest resident set its system monitor sampled during the run.

    python tests/peers/bench_dask.py --isokit target/release/isokit [--res 768] [--mem-res 1024]

Needs the isokit package (maturin develop --release) and dask[array,distributed], zarr.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "examples" / "scenes" / "demo.json"


def peak_memory_mib(dask_worker):
    """The worker's own memory report: the largest resident set its system monitor sampled
    (every 0.5 s) during the run."""
    return max(dask_worker.monitor.quantities["memory"]) / 2**20


def run_cluster(n, shape, res, chunks, out, threads=None):
    """Samples on `n` worker processes of one Dask thread each; `threads`: the sampler's
    own threads per worker (RAYON_NUM_THREADS; default all cores)."""
    import distributed

    import isokit.dask as idk

    env = {"RAYON_NUM_THREADS": str(threads)} if threads else None
    with distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                  dashboard_address=None, env=env) as cluster, \
            distributed.Client(cluster) as client:
        client.run(lambda: __import__("isokit"))
        arr = idk.sample(shape, res=res, chunks=chunks)
        t = time.perf_counter()
        idk.to_zarr(arr, out)
        seconds = time.perf_counter() - t
        time.sleep(1.0)  # one more monitor sample
        rss = list(client.run(peak_memory_mib).values())
    blocks = int(np.prod([len(c) for c in arr.chunks]))
    return seconds, blocks, rss


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isokit", default=str(ROOT / "target" / "release" / "isokit"))
    ap.add_argument("--res", type=int, default=768)
    ap.add_argument("--mem-res", type=int, default=1024)
    ap.add_argument("--configs", type=int, default=5, help="how many cluster setups to run")
    args = ap.parse_args()

    import zarr

    import isokit

    shape = isokit.load_scene(DEMO)
    tmp = Path(tempfile.mkdtemp(prefix="isokit-bench-dask-"))
    rows = []
    try:
        ref = tmp / "cli.zarr"
        subprocess.run([args.isokit, "scene", DEMO, "--res", str(args.res), "-o", ref],
                       check=True, capture_output=True)
        want = zarr.open_group(str(ref))["field"][:]
        # The one-process baseline: the same extension the workers run, the whole lattice
        # in one call, on 1 and on 2 threads (a fresh process each, for RAYON_NUM_THREADS).
        one = {}
        # Sampled, then written as the same store (gzip level 1, chunks of 64³) by
        # zarr-python on one thread: what the Dask path does, without Dask.
        code = ("import isokit, isokit.dask as idk, time, sys, dask, dask.array as da; "
                "s = isokit.load_scene(sys.argv[1]); t = time.perf_counter(); "
                "f = s.sample(res=int(sys.argv[2])); lat = idk.lattice_of(idk.sample(s, res=int(sys.argv[2]))); "
                "dask.config.set(scheduler='synchronous'); "
                "idk.to_zarr(da.from_array(f.values, chunks=64), sys.argv[3], lattice=lat); "
                "print(time.perf_counter() - t)")
        for threads in (1, 2):
            env = {**os.environ, "RAYON_NUM_THREADS": str(threads)}
            r = subprocess.run([sys.executable, "-c", code, str(DEMO), str(args.res),
                                str(tmp / f"one{threads}.zarr")],
                               check=True, capture_output=True, text=True, env=env)
            one[threads] = float(r.stdout.strip())
        print(f"res {args.res}: lattice {want.shape[::-1]}; one process (shape.sample + the "
              f"store written): "
              f"{one[1]:.2f} s on 1 thread, {one[2]:.2f} s on 2")
        for n, threads, chunks in [(1, 1, 64), (2, 1, 64), (1, None, 64), (2, 1, 32),
                                   (2, 1, 128)][: args.configs]:
            out = tmp / f"d{n}_{threads}_{chunks}.zarr"
            seconds, blocks, rss = run_cluster(n, shape, args.res, chunks, out, threads)
            same = np.array_equal(zarr.open_group(str(out))["field"][:], want)
            cores = n * (threads or 2)
            rows.append({"workers": n, "sampler_threads": threads or "all", "chunks": chunks,
                         "blocks": blocks, "seconds": round(seconds, 2),
                         "speedup_vs_one_thread": round(one[1] / seconds, 2),
                         "core_ms_per_block_over_one_thread": round(
                             1000.0 * (seconds * min(cores, 2) - one[1]) / blocks, 2),
                         "worker_peak_mib": [round(r) for r in rss], "identical": same})
            print(json.dumps(rows[-1]), flush=True)
            shutil.rmtree(out, ignore_errors=True)
        if args.mem_res:
            out = tmp / "mem.zarr"
            seconds, blocks, rss = run_cluster(2, shape, args.mem_res, 64, out, 1)
            g = zarr.open_group(str(out))
            dims = g.attrs["dims"]
            rows.append({"workers": 2, "chunks": 64, "res": args.mem_res, "dims": dims,
                         "blocks": blocks, "seconds": round(seconds, 2),
                         "dense_gib": round(float(np.prod(dims)) * 4 / 2**30, 2),
                         "worker_peak_mib": [round(r) for r in rss]})
            print(json.dumps(rows[-1]), flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
