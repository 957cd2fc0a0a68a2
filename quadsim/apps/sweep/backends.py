"""Running many independent tasks: in this process, on a pool of processes over this machine's
cores, or as Ray tasks on a local instance or a cluster. The same task function and the same
results either way (tasks are pure functions of their input); results arrive as they finish.

Stopping: the first Ctrl-C / SIGTERM stops handing out work and waits for the tasks already
running (their results are kept); a second one abandons them. Workers ignore both signals, so a
Ctrl-C sent to the whole process group reaches only this process's handler.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, TypeVar

from quadsim.core.invocation import install_extra
from quadsim.errors import QuadsimError
from quadsim.session.stopping import HANDLED, stop_requested

T = TypeVar("T")
R = TypeVar("R")


def ray_missing() -> str:
    """What to do when Ray is asked for and is not installed."""
    return f"Ray is not installed: {install_extra('ray')}"


_STOP_SIGNALS = set(HANDLED)


def _ignore_signals() -> None:
    """Pool and Ray workers leave stopping to the process that owns them."""
    for signum in _STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)  # ignored now: nothing pending is kept


@contextmanager
def _signals_blocked() -> Iterator[None]:
    """While worker processes are started: a signal sent to the whole group now stays pending
    for this process (and is handled right after) and never reaches a worker still importing,
    which inherits the blocked mask until its initializer ignores the signals."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def default_jobs() -> int:
    """Every core this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def run_serial(fn: Callable[[T], R], tasks: Sequence[T]) -> Iterator[R]:
    for task in tasks:
        if stop_requested():
            return
        yield fn(task)


def start_method() -> str:
    """How the pool's workers start. Forked on Linux while this process runs no other thread: a
    worker then starts with everything this process has loaded (the flight stack, the compiled
    flight core), where a spawned one spends about half a second importing and loading them, a
    tenth of a short sweep on two cores. Spawned otherwise: forking a process with threads can
    leave a lock held forever in the worker (Python 3.12 warns of it), and macOS's system
    libraries do not survive a fork. Threads started outside Python count too (OpenBLAS's pool,
    which numpy starts on import unless OPENBLAS_NUM_THREADS=1, as the command line sets it; a
    ROS 2 executor; PyBullet's window). (A forked worker never uses a PyBullet client this
    process may hold: every run builds its own.)"""
    import multiprocessing

    if sys.platform == "linux" and _threads() == 1 and "fork" in multiprocessing.get_all_start_methods():
        return "fork"
    return "spawn"


def _threads() -> int:
    """This process's threads, Python's and others (Linux's count; Python's where it cannot be read)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return threading.active_count()


def run_pool(fn: Callable[[T], R], tasks: Sequence[T], jobs: int) -> Iterator[R]:
    """Results in completion order from `jobs` worker processes (see `start_method`). At most
    2 x jobs tasks are queued at a time, so a stop leaves little behind."""
    import multiprocessing

    if jobs <= 1:
        yield from run_serial(fn, tasks)
        return
    context = multiprocessing.get_context(start_method())  # a fork flushes stdout and stderr first
    executor = ProcessPoolExecutor(jobs, mp_context=context, initializer=_ignore_signals)
    pending: set[Future[R]] = set()
    todo = iter(tasks)
    abandoned = False
    try:
        while True:
            while not stop_requested() and len(pending) < 2 * jobs:
                task = next(todo, None)
                if task is None:
                    break
                with _signals_blocked():  # submit may start a worker process
                    pending.add(executor.submit(fn, task))
            if not pending:
                return
            done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            for future in done:
                try:
                    yield future.result()
                except Exception as exc:  # a worker that died (killed, out of memory, a crash in C)
                    raise QuadsimError(f"a worker process failed: {type(exc).__name__}: {exc}") from None
    except BaseException:  # a second Ctrl-C (StopRequested), an error, or the caller stopped reading
        abandoned = True
        raise
    finally:
        if abandoned:  # the workers ignore SIGTERM (the stop is this process's): killed, not waited for
            # (no public API for the processes before 3.14; shutdown forgets them, so asked first)
            for process in list((getattr(executor, "_processes", None) or {}).values()):
                process.kill()
        executor.shutdown(wait=not abandoned, cancel_futures=True)


def ray_available() -> bool:
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


def ray_runtime_env() -> dict[str, Any]:
    """What a Ray cluster needs to run quadsim's tasks: the quadsim package itself (uploaded by
    Ray from this machine) and its dependencies (installed by Ray on the workers)."""
    from importlib import metadata

    import quadsim

    requirements = [r.split(";")[0].strip() for r in metadata.requires("quadsim") or [] if "extra ==" not in r]
    return {"py_modules": [os.path.dirname(quadsim.__file__)], "pip": requirements}


def run_ray(fn: Callable[[T], R], tasks: Sequence[T], address: str | None, jobs: int) -> Iterator[R]:
    """Results in completion order from Ray tasks: on a local Ray instance with `jobs` CPUs when
    `address` is None, else on the cluster at `address` ("auto", "ray://host:10001")."""
    try:
        import ray
    except ImportError:
        raise QuadsimError(ray_missing()) from None
    kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False}
    if address is None:
        kwargs["num_cpus"] = jobs
    else:
        kwargs["address"] = address
        kwargs["runtime_env"] = ray_runtime_env()
    owner = not ray.is_initialized()  # else the caller's Ray (the bench times its start-up apart)
    if owner:
        try:
            with _signals_blocked():  # Ray's own processes start now: a Ctrl-C is this process's
                ray.init(**kwargs)
        except Exception as exc:
            raise QuadsimError(f"cannot start or reach Ray{f' at {address}' if address else ''}: {exc}") from None
    remote: Any = ray.remote(num_cpus=1, max_retries=0)(_ray_task)
    pending: list[Any] = []
    todo = iter(tasks)
    window = 2 * max(jobs, int(ray.cluster_resources().get("CPU", jobs)))
    try:
        while True:
            while not stop_requested() and len(pending) < window:
                task = next(todo, None)
                if task is None:
                    break
                pending.append(remote.remote(fn, task))
            if not pending:
                return
            done, pending = ray.wait(pending, num_returns=1, timeout=0.2)
            for ref in done:
                try:
                    yield ray.get(ref)
                except Exception as exc:
                    raise QuadsimError(f"a Ray task failed: {type(exc).__name__}: {exc}") from None
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if owner:
            ray.shutdown()


def _ray_task(fn: Callable[[T], R], task: T) -> R:
    _ignore_signals()
    return fn(task)


def run_tasks(
    fn: Callable[[T], R],
    tasks: Sequence[T],
    jobs: int = 1,
    ray_address: str | None = None,
    use_ray: bool = False,
) -> Iterator[R]:
    """Dispatch to the back-end asked for."""
    if use_ray:
        return run_ray(fn, tasks, ray_address, jobs)
    return run_pool(fn, tasks, jobs)
