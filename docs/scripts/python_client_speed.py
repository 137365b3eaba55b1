#!/usr/bin/env python3
"""How fast the Python client answers: a unary call's round trip, and
bringing a snapshot's fields into numpy.

First CALLS (200) GetJob calls one after the other: the median and 90th
percentile of their round trip.

Submits scenes/two_disks.toml with its cells made finer (CELL, default
0.003125 m: 103 k particles) and its end cut (END, default 0.01 s), waits,
then fetches the latest snapshot's particle fields REPEATS times (all
fields, then position alone) and the series, and prints the seconds and
MB/s per fetch (median), with the same fetch by `cleave fetch` (which also
writes every snapshot's VTK files) for scale.

  cargo build --release --workspace --bins
  target/release/cleave-server --listen 127.0.0.1:50061 --data-dir /tmp/fs-data &
  python docs/scripts/python_client_speed.py http://127.0.0.1:50061 [CELL] [END] [REPEATS]
"""
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cleave_client import Client

REPO = Path(__file__).resolve().parents[2]
url = sys.argv[1]
cell = float(sys.argv[2]) if len(sys.argv) > 2 else 0.003125
end = float(sys.argv[3]) if len(sys.argv) > 3 else 0.01
repeats = int(sys.argv[4]) if len(sys.argv) > 4 else 5

scene = ((REPO / "scenes" / "two_disks.toml").read_text()
         .replace("cell_size = 0.0125", f"cell_size = {cell}")
         .replace("end = 3.0", f"end = {end}"))
with Client(url) as c:
    job = c.submit(scene, label="fetch speed")
    job.wait()

    def timed(f):
        times, out = [], None
        for _ in range(repeats):
            t = time.perf_counter()
            out = f()
            times.append(time.perf_counter() - t)
        return statistics.median(times), out

    rt = []
    for _ in range(200):
        t = time.perf_counter()
        job.info()
        rt.append(time.perf_counter() - t)
    rt.sort()
    print(f"GetJob round trip: median {1e3 * rt[100]:.2f} ms, 90th percentile {1e3 * rt[180]:.2f} ms (200 calls)")
    t_all, fields = timed(lambda: job.fields())
    mb = sum(a.nbytes for a in fields.values()) / 1e6
    t_pos, pos = timed(lambda: job.fields(names=["position"]))
    t_ser, series = timed(lambda: job.series())
    print(f"{fields.snapshot.particles} particles, snapshot {fields.snapshot.index}, {len(fields)} fields, {mb:.1f} MB")
    print(f"fields (all):      {t_all:.3f} s  {mb / t_all:.0f} MB/s")
    print(f"fields (position): {t_pos:.3f} s  {pos['position'].nbytes / 1e6 / t_pos:.0f} MB/s")
    print(f"series:            {t_ser:.4f} s  ({len(series)} rows, {len(series.dtype.names)} columns)")
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        subprocess.run([str(REPO / "target" / "release" / "cleave"), "--server", url, "fetch", job.id,
                        "--out", d], check=True, capture_output=True)
        print(f"cleave fetch (every snapshot, VTK written): {time.perf_counter() - t:.3f} s, "
              f"{fields.snapshot.index + 1} snapshots")
