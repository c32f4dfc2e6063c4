"""The process-wide facts and settings of yore: its version, what its core was built with, its
thread count (re-exported by `yore`: `yore.build_info`, `yore.set_num_threads`) and the `yore`
command's handling of Ctrl-C while it starts. Imports only the standard library at first: the
command's script calls `start_command` before anything heavy loads."""

from __future__ import annotations

import contextlib
import numbers
import os
import signal
import sys
import threading

__all__ = [
    "VERSION",
    "build_info",
    "set_num_threads",
    "use_thread_defaults",
    "start_command",
    "is_command",
    "end_command_start",
    "end_command",
    "deferred_interrupt",
]

#: yore's version (also `yore.__version__`).
VERSION = "0.1.0"


def build_info() -> dict:
    """Versions of the libraries yore was built and linked with, the BLAS kernels in use
    (``blas_kernel``, ``blas_kernel_chosen_by``: "user", "yore" or "openblas",
    ``blas_kernel_tier``, ``blas_library``, ``cpu_kernel``: the widest this CPU runs; see
    `yore.blas`), and its thread counts (``threads``: its loops'; ``blas_threads``: the BLAS's,
    0 where the BLAS cannot say)."""
    from . import _core

    from . import blas

    info = dict(_core.build_info())
    kernels = blas.report()
    info["blas_kernel_chosen_by"] = kernels["chosen_by"]
    info["blas_kernel_tier"] = kernels["tier"]
    info["blas_library"] = ", ".join(kernels["library"])
    info["cpu_kernel"] = kernels["cpu_kernel"] or ""
    info["threads"] = _core.max_threads()
    info["blas_threads"] = _core.blas_threads()
    info["yore"] = VERSION
    return info


def set_num_threads(threads: int) -> None:
    """Sets the threads of yore's parallel loops and of the BLAS that CHOLMOD calls (OpenBLAS),
    for the whole process: the one place the thread count is set (``yore --threads N`` and a
    scene's ``[simulation] threads`` call it). Raises ValueError unless `threads` is an int >= 1
    (bool is refused).

    The explicit step still runs a block of steps on one thread when that is faster (small
    cloths, or a machine busy with other processes); ``Simulation.stats["threads"]`` says what
    its loops used.
    """
    from . import _core
    from .checks import MAX_THREADS

    if (
        isinstance(threads, bool)
        or not isinstance(threads, numbers.Integral)
        or not 1 <= threads <= MAX_THREADS
    ):
        raise ValueError(
            f"the number of threads must be an int in [1, {MAX_THREADS}], got {threads!r}"
        )
    most = threads_the_address_space_holds()
    if most is not None and threads > most:
        raise ValueError(
            f"{threads} threads do not fit in this process's address-space limit (ulimit -v): "
            f"each reserves about {THREAD_ADDRESS_SPACE >> 20} MiB (stacks, malloc arenas, "
            f"BLAS buffers) beside {PROCESS_ADDRESS_SPACE >> 20} MiB for the rest, so {most} "
            f"fit; use at most {most} threads"
        )
    _core.set_max_threads(int(threads))


#: Address space a thread of yore's may reserve, bytes, from above: an OpenMP and an OpenBLAS
#: thread each with its stack, its malloc arena (64 MiB of address space) and BLAS buffers
#: (measured: under a 3 GiB limit 12 threads ran, 16 never started, hanging).
THREAD_ADDRESS_SPACE = 256 << 20


#: Address space set aside for yore itself (its libraries, the interpreter, a cloth's arrays)
#: before threads are counted, bytes: a fixed allowance, so the answer does not depend on the
#: moment it is asked (what a process holds varies by a few hundred MiB as threads start).
PROCESS_ADDRESS_SPACE = 1 << 30


def threads_the_address_space_holds():
    """Threads that fit in this process's address-space limit (RLIMIT_AS, ``ulimit -v``):
    (limit − `PROCESS_ADDRESS_SPACE`) / `THREAD_ADDRESS_SPACE`, at least 1; None without a
    limit."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, OSError, ValueError):
        return None
    if limit == resource.RLIM_INFINITY:
        return None
    return max(1, (limit - PROCESS_ADDRESS_SPACE) // THREAD_ADDRESS_SPACE)


def use_thread_defaults() -> None:
    """yore's recommended thread settings for a process (what the `yore` command uses; a
    program calls it, or `set_num_threads`, when it wants them; ``import yore`` changes none):
    one BLAS thread, unless ``OPENBLAS_NUM_THREADS``, ``GOTO_NUM_THREADS`` or
    ``OMP_NUM_THREADS`` chose (OpenBLAS's threads, CHOLMOD's factorization, wait for each other
    like OpenMP's, and no step re-times them: on a busy machine two made a linearized implicit
    step 3× slower); and under an address-space limit (``ulimit -v``) no more OpenMP threads
    than fit, since the creation of more hangs."""
    from . import _core
    from .blas import THREAD_VARIABLES

    if not any(name in os.environ for name in THREAD_VARIABLES):
        _core.set_blas_threads(1)
    most = threads_the_address_space_holds()
    if most is not None and _core.max_threads() > most:
        _core.set_max_threads(most)


# The `yore` command: while it starts (its imports, the core's load), a Ctrl-C is one line and
# exit 130 (a traceback of the imports otherwise). Only for the command (`start_command`, called
# by its script and by ``python -m yore``): a program importing yore keeps its own handling. When
# main() has returned, the interpreter's shutdown is all that is left: a Ctrl-C there has
# nothing to interrupt, and Python would print "Exception ignored in ..." with a traceback and
# still exit 0 (end_command).
_guarding = [False]
_command = [False]  # this process is the `yore` command


#: Set in the environment of the worker processes a sweep's local cluster starts
#: (`yore.sweep.run`): they ignore Ctrl-C (the terminal's Ctrl-C reaches the whole process group;
#: only the client acts on it, closing the cluster).
SWEEP_WORKER_ENV = "YORE_SWEEP_WORKER"


def ignore_interrupts_in_sweep_workers() -> None:
    """In a sweep's worker process (`SWEEP_WORKER_ENV` set), SIGINT is ignored from here on.
    Called by what such a worker imports first: the `yore` command's entry module (its main module
    when the sweep runs from the command) and the sweep's Dask preload (`yore.sweep.worker`)."""
    if (
        os.environ.get(SWEEP_WORKER_ENV) == "1"
        and threading.current_thread() is threading.main_thread()
    ):
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _interrupted_while_starting(number, frame):  # pragma: no cover - exits the process
    print("yore: interrupted", file=sys.stderr, flush=True)
    os._exit(130)


def start_command() -> None:
    """This process is the `yore` command: in its main thread, while Python's own Ctrl-C
    handling is in place, a Ctrl-C ends the process with one line and exit 130 until
    `end_command_start`."""
    from . import _start_guard

    if threading.current_thread() is threading.main_thread() and signal.getsignal(
        signal.SIGINT
    ) in (signal.default_int_handler, _start_guard.interrupted):
        signal.signal(signal.SIGINT, _interrupted_while_starting)
        _guarding[0] = True
    _command[0] = True
    from . import blas  # (after the guard: its imports take a few milliseconds)

    blas.mark_command()


def is_command() -> bool:
    """This process is the `yore` command (known from `start_command` on)."""
    return _command[0]


def end_command_start() -> None:
    """The command has started: Ctrl-C raises KeyboardInterrupt again, for its main() to handle
    (unless something else took SIGINT meanwhile)."""
    if _guarding[0] and signal.getsignal(signal.SIGINT) is _interrupted_while_starting:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    _guarding[0] = False


def end_command() -> None:
    """The `yore` command's main() is done and its exit code decided: from here on a Ctrl-C is
    ignored, so that one landing in the interpreter's shutdown prints nothing (everything the
    command writes is written and closed before main() returns)."""
    if _command[0] and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def deferred_interrupt():
    """Ctrl-C inside the block is held back until the block is done, so bookkeeping that must
    not be split (a frame and its record, a saved state) completes. Main thread only; elsewhere
    the block runs as it is."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(
        signal.SIGINT
    ) in (signal.SIG_IGN, None):
        # elsewhere, or where SIGINT is ignored (nohup, a parent's choice): nothing to defer,
        # and a handler of ours would make Ctrl-C stop a run that was started not to stop
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda number, frame: caught.append(number))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt
