"""The Python package's overhead, for the performance table.

    python python/bench/overhead.py [RUNS]

1. ``Scenario.run`` from Python against the same runs from Rust alone
   (``_bench_native``: a loop over the library's ``Scenario::run``), the
   in-process spiral, RUNS runs each (default 100), interleaved in rounds
   so that both see the same machine. The goal: Python adds under 10 %, or
   under 1 ms a run, whichever is larger.
2. The DataFrame of a 10,000-sample track: ``run.track`` (the table's cells
   made, typed and handed to numpy and pandas), best of 5.
"""

import sys
import time

import sonarnet

runs = int(sys.argv[1]) if len(sys.argv) > 1 else 100
sc = sonarnet.Scenario.builtin("mourya2017-spiral")
sc.run(engine="inprocess", progress=False)  # warm-up

rounds = 5
per = max(1, runs // rounds)
native = python = 0.0
for _ in range(rounds):
    native += sonarnet._sonarnet._bench_native(sc._s, per)
    t = time.perf_counter()
    for _ in range(per):
        sc.run(engine="inprocess", progress=False)
    python += time.perf_counter() - t
n = per * rounds
extra_ms = (python - native) / n * 1e3
ratio = python / native
print(f"spiral in-process, {n} runs: Rust {native / n * 1e3:.3f} ms/run, Python {python / n * 1e3:.3f} ms/run")
print(f"  overhead {extra_ms:+.3f} ms/run, ratio {ratio:.3f} (goal: < 1.10 or < 1 ms)")

big = sc.with_overrides({"target.samples": 10000})
run = big.run(engine="inprocess", progress=False)
best = float("inf")
for _ in range(5):
    fresh = sonarnet.Run(run._n)  # no cached DataFrame
    t = time.perf_counter()
    df = fresh.track
    best = min(best, time.perf_counter() - t)
print(f"track DataFrame of {len(df)} samples x {len(df.columns)} columns: {best * 1e3:.1f} ms")
ok = ratio < 1.10 or extra_ms < 1.0
print("goal met" if ok else "goal NOT met")
