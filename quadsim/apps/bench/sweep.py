"""The sweep section of `bench`: a 64-run sweep of 20 s flights without cameras, with one worker
(in this process), a process pool over every core, and a local Ray instance; speed-up against
one worker, and Ray's overhead per run."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from quadsim.apps.sweep.backends import default_jobs, ray_available, run_tasks, start_method
from quadsim.apps.sweep.execute import hand_out_order
from quadsim.apps.sweep.run import RunTask, fly_run, forget_simulators
from quadsim.apps.sweep.spec import RunSpec, SweepSpec, load_sweep
from quadsim.core.invocation import install_extra

BENCH_SWEEP = """
name = "bench"
scenarios = ["hover", "square", "figure8", "step_forward"]
duration_s = 20.0
seeds = 8
[controllers.cascade]
kind = "cascade"
[controllers.seed]
kind = "seed"
"""


def _bench_spec(folder: Path) -> SweepSpec:
    path = folder / "bench_sweep.toml"
    path.write_text(BENCH_SWEEP)
    return load_sweep(path)


def _import_flight_stack(_: int) -> int:
    """A task that only loads what a run needs (a worker's start-up, measured apart)."""
    import quadsim.sim.simulator  # noqa: F401  (pybullet, numpy, the controllers)

    return 0


def _startup_s(jobs: int, use_ray: bool = False) -> float:
    """Wall time of `jobs` tasks that only import the flight stack: the workers' start-up."""
    t0 = time.perf_counter()
    list(run_tasks(_import_flight_stack, list(range(jobs)), jobs, None, use_ray))
    return time.perf_counter() - t0


def _timed(tasks: list[RunTask], jobs: int, use_ray: bool = False) -> tuple[float, list[dict]]:
    """Wall time of the sweep's runs, handed out as `sweep` hands them out, and their rows."""
    t0 = time.perf_counter()
    try:
        rows = list(run_tasks(fly_run, sorted(tasks, key=hand_out_order), jobs, None, use_ray))
    finally:
        forget_simulators()  # those this process kept (1 worker)
    return time.perf_counter() - t0, sorted(rows, key=lambda r: r["index"])


def _same(rows: list[dict], reference: list[dict]) -> str:
    """Whether two back-ends gave the same rows (compared as text: NaN equals NaN)."""
    return "same table" if [repr(r) for r in rows] == [repr(r) for r in reference] else "TABLE DIFFERS"


def run_sweep_bench(out: Callable[[str], None] = print) -> None:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="quadsim-bench-") as tmp:
        spec = _bench_spec(Path(tmp))
    runs: tuple[RunSpec, ...] = spec.runs
    tasks = [RunTask(run) for run in runs]
    cores = default_jobs()
    out(f"sweep: {len(runs)} runs of 20 s flights, no cameras, on {cores} cores")
    serial_s, reference = _timed(tasks, 1)
    out(f"  1 worker (this process)   {serial_s:6.2f} s   {len(runs) / serial_s:6.1f} runs/s   1.00x")
    method = start_method()  # what the pool below does
    pool_s, rows = _timed(tasks, cores)
    same = _same(rows, reference)
    speedup = serial_s / pool_s
    startup = _startup_s(cores)  # a fresh pool's workers importing the flight stack (forked: already loaded)
    warm = serial_s / max(pool_s - startup, 1e-9)
    out(
        f"  {cores} worker processes      {pool_s:6.2f} s   {len(runs) / pool_s:6.1f} runs/s   {speedup:.2f}x "
        f"({speedup / cores:.2f} of the core count with the workers' {startup:.1f} s start-up, "
        f"{warm / cores:.2f} without; target 0.85; workers {method}ed) [{same}]"
    )
    if not ray_available():
        out(f"  Ray                       not installed ({install_extra('ray')})")
        return
    import ray

    t0 = time.perf_counter()
    ray.init(num_cpus=cores, include_dashboard=False, log_to_driver=False, configure_logging=False)
    start_s = time.perf_counter() - t0
    try:
        warmup_s = _startup_s(cores, use_ray=True)  # Ray's workers start and import the flight stack
        ray_s, rows = _timed(tasks, cores, use_ray=True)
    finally:
        ray.shutdown()
    same = _same(rows, reference)
    # the time Ray adds to each run against the process pool on the same cores (what Ray itself costs:
    # scheduling, serialising, its object store), in a worker's time
    overhead_ms = (ray_s - pool_s) * cores / len(runs) * 1000
    out(
        f"  local Ray, {cores} CPUs        {ray_s:6.2f} s   {len(runs) / ray_s:6.1f} runs/s   {serial_s / ray_s:.2f}x "
        f"(+{start_s:.1f} s to start Ray and {warmup_s:.1f} s for its workers' imports; overhead against "
        f"the pool {overhead_ms:+.1f} ms per run, target < 50) [{same}]"
    )
