"""Where units of work run: in this process, or on Dask distributed.

Both executors take a function ``fn(ctx, unit) -> record`` and yield
``(unit, record)`` as units finish.  Units are idempotent, so a unit that runs
twice (a Dask worker that died and whose task Dask re-ran) writes the same files
again; the driver records what finished.

Dask: a ``LocalCluster`` on 127.0.0.1 with its dashboard off (unless asked;
then at http://127.0.0.1:8787), or the cluster at ``address``
(``tcp://HOST:PORT``), which is probed first (:func:`check_scheduler`, a few
seconds at most): a scheduler that cannot be reached is bad input
(:class:`ExecutorError`), not a 30 s wait.  Workers use JAX's persistent compilation cache
(:func:`enable_compilation_cache`), so each worker process compiles a kernel
once per machine and later runs start warm; a local run uses it for the run's
duration only (:func:`compilation_cache`).
"""
from __future__ import annotations

import contextlib
import os
import pathlib
import socket
from typing import Callable, Iterable, Iterator

from distributed.diagnostics.plugin import WorkerPlugin

CACHE_ENV = "NUDGE_JAX_CACHE"
#: Seconds to wait for a TCP connection to a scheduler (the probe), and for the client's handshake.
PROBE_TIMEOUT_S, CONNECT_TIMEOUT_S = 3.0, 10.0


class ExecutorError(RuntimeError):
    """The executor cannot start: the scheduler address is malformed or nothing
    answers there (bad input; the message names ``executor.address`` and the fix)."""


def _unreachable(address: str, why) -> str:
    return (f"executor.address: cannot reach the Dask scheduler at {address} ({why}); start one "
            "(dask scheduler) or use executor: local")


def _connect(address: str, timeout_s: float | None = None):
    """A Dask ``Client`` of the scheduler at ``address``, or one
    :class:`ExecutorError` line within ``timeout_s`` seconds: something that
    accepts connections but is no scheduler either never answers Dask's
    handshake (an HTTP server: the client's own timeout does not cover that
    wait) or answers bytes that Dask reads as a frame length (once 3 EiB: a
    MemoryError).  The client is made in a daemon thread, abandoned on timeout."""
    import threading

    from dask.distributed import Client

    timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else timeout_s
    box: dict = {}

    def make():
        try:
            box["client"] = Client(address, timeout=f"{timeout_s:g}s")
        except BaseException as exc:   # noqa: BLE001 - reported below, in this thread's caller
            box["error"] = exc

    t = threading.Thread(target=make, name="nudge-dask-connect", daemon=True)
    t.start()
    t.join(timeout_s + 1.0)
    not_dask = (f"executor.address: something answers at {address} but it is not a Dask "
                "scheduler ({why}); give the scheduler's address (dask scheduler prints it, "
                "tcp://HOST:8786 by default) or leave executor.address out for a local cluster")
    if t.is_alive():
        raise ExecutorError(not_dask.format(why=f"no Dask handshake in {timeout_s:g} s"))
    exc = box.get("error")
    if isinstance(exc, OSError):     # the handshake timed out or the connection closed
        raise ExecutorError(_unreachable(address, exc))
    if isinstance(exc, Exception):   # bytes read as a Dask frame: MemoryError, ValueError, ...
        raise ExecutorError(not_dask.format(
            why=f"its reply is no Dask message: {type(exc).__name__}: "
                f"{' '.join(str(exc).split())[:80]}"))
    if exc is not None:              # KeyboardInterrupt, SystemExit
        raise exc
    return box["client"]


def check_scheduler(address: str, timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Check, within ``timeout_s`` seconds, that something listens at a Dask
    scheduler address (``tcp://HOST:PORT`` or ``tls://HOST:PORT``: a TCP
    connection is opened and closed; other transports are left to the client).

    Raises:
      ExecutorError: a malformed address, or no connection (refused, timed
        out, unknown host).
    """
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return
        host, port = parse_host_port(loc)
    except ValueError as exc:
        raise ExecutorError(f"executor.address: expected tcp://HOST:PORT (e.g. "
                            f"tcp://10.0.0.5:8786), got {address!r} ({exc})") from None
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except socket.timeout:
        raise ExecutorError(_unreachable(address, f"no answer in {timeout_s:g} s")) from None
    except OSError as exc:
        raise ExecutorError(_unreachable(address, exc.strerror or exc)) from None


def cache_dir() -> str:
    """The persistent compilation cache folder (``$NUDGE_JAX_CACHE``, default
    ``~/.cache/nudge/jax``; an empty value disables the cache)."""
    return os.environ.get(CACHE_ENV, str(pathlib.Path.home() / ".cache" / "nudge" / "jax"))


def enable_compilation_cache(folder: str | None = None) -> None:
    """Persist compiled kernels across processes and runs, for the rest of this
    process (a Dask worker's: nudge owns it).  Every kernel, however quick to
    compile: the quick ones are most of a small study's start-up (the tests'
    two-configuration study, warm: 7.0-7.3 s against 9.3 s when only
    compilations over 0.5 s were kept; its cache holds 88 entries, 1.2 MB).
    An optimisation: any failure leaves JAX as it was.  In a caller's process
    use :func:`compilation_cache`, which puts JAX's settings back afterwards."""
    d = cache_dir() if folder is None else folder
    if not d:
        return
    try:
        import jax

        pathlib.Path(d).mkdir(parents=True, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", d)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    except Exception:  # noqa: BLE001 - a cache is never a reason to fail
        pass


@contextlib.contextmanager
def compilation_cache(folder: str | None = None):
    """The persistent compilation cache for the duration of a ``with`` block
    (a local run, a certification), then JAX's settings as they were: a run
    called from Python does not leave the caller's process writing every later
    compilation into nudge's cache."""
    import jax

    keys = ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")
    before = {k: getattr(jax.config, k) for k in keys}
    enable_compilation_cache(folder)
    changed = any(getattr(jax.config, k) != v for k, v in before.items())
    try:
        yield
    finally:
        if changed:
            try:
                from jax.experimental.compilation_cache import compilation_cache as cc

                for k, v in before.items():
                    jax.config.update(k, v)
                cc.reset_cache()   # forget the opened folder: the next compile re-reads the settings
            except Exception:  # noqa: BLE001 - as above
                pass


class LocalExecutor:
    """Runs units one after the other in this process; a unit's files are
    written by a background thread while the next unit computes
    (:func:`sweeps.parquet.write_behind`), and its record is yielded once they
    are on disk."""

    name = "local"

    def __enter__(self):
        self._cache = compilation_cache()
        self._cache.__enter__()
        return self

    def __exit__(self, *exc):
        self._cache.__exit__(*exc)
        return False

    def run(self, fn: Callable, ctx, units: Iterable) -> Iterator:
        from sweeps.parquet import write_behind

        def handed_over(entry):
            """A computed unit's ``(unit, record)``, once its files are on disk."""
            u, rec, writes = entry
            w.wait(writes)
            return u, rec

        with write_behind() as w:
            ready = None                     # (unit, record, its writes) not yet yielded
            for u in units:
                try:
                    with w.deferring():
                        rec = fn(ctx, u)
                except BaseException:
                    if ready is not None:    # the unit before still counts as done
                        yield handed_over(ready)
                    raise
                done, ready = ready, (u, rec, w.take())
                if done is not None:
                    yield handed_over(done)
            if ready is not None:
                yield handed_over(ready)


class DaskExecutor:
    """Runs units on Dask distributed (see the module docstring)."""

    name = "dask"

    def __init__(self, workers: int = 2, threads_per_worker: int = 1, address: str | None = None,
                 dashboard: bool = False):
        self.workers, self.threads = int(workers), int(threads_per_worker)
        self.address, self.dashboard = address, bool(dashboard)
        self.client = self.cluster = None
        self._futures: list = []

    def __enter__(self):
        from distributed import Client, LocalCluster

        d = cache_dir()
        # a worker's MuJoCo rollouts run on its own threads only (cpu_threads)
        env = {"JAX_PLATFORMS": "cpu", "NUDGE_THREADS": str(self.threads)}
        if d:  # worker processes inherit the environment, and JAX reads its flags from it
            env.update(JAX_COMPILATION_CACHE_DIR=d, JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0")
        # set for the workers only: put back on exit (a caller's later subprocesses do not inherit them)
        self._env = {k: None for k in env if k not in os.environ}
        for k, v in env.items():
            os.environ.setdefault(k, v)
        # a worker's compiled replays spread over as many CPU devices as it has threads
        # (robustness.replay.replay_devices), whatever this process was given
        self._env["JAX_NUM_CPU_DEVICES"] = os.environ.get("JAX_NUM_CPU_DEVICES")
        os.environ["JAX_NUM_CPU_DEVICES"] = str(self.threads)
        if self.address:
            check_scheduler(self.address)
            self.client = _connect(self.address)
        else:
            # loopback only; without the dashboard the scheduler's small HTTP server (health,
            # metrics) takes a free loopback port instead of 8787
            self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=self.threads,
                                        processes=True, host="127.0.0.1",
                                        dashboard_address="127.0.0.1:8787" if self.dashboard
                                        else "127.0.0.1:0",
                                        scheduler_kwargs={"dashboard": self.dashboard},
                                        silence_logs=50)
            self.client = Client(self.cluster)
        self.client.register_plugin(_CachePlugin(d))
        return self

    def __exit__(self, *exc):
        for f in self._futures:
            f.cancel()
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        for k, v in getattr(self, "_env", {}).items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        return False

    def run(self, fn: Callable, ctx, units: Iterable) -> Iterator:
        from distributed import as_completed

        units = list(units)
        futures = {self.client.submit(fn, ctx, u, key=f"nudge-{u.key}-{id(ctx)}", pure=False): u
                   for u in units}
        self._futures = list(futures)
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
        self._futures = []


class _CachePlugin(WorkerPlugin):
    """Worker plugin: enable the persistent compilation cache in every worker,
    including workers that join (or restart) later."""

    name = "nudge-jax-cache"

    def __init__(self, folder: str):
        self.folder = folder

    def setup(self, worker=None):
        enable_compilation_cache(self.folder)

    def teardown(self, worker=None):
        pass


def make_executor(spec):
    """The executor of an :class:`~sweeps.study.Executor` spec."""
    if spec.kind == "dask":
        return DaskExecutor(spec.workers, spec.threads_per_worker, spec.address, spec.dashboard)
    return LocalExecutor()
