"""The Dask preload of a sweep's worker processes (`yore.sweep.run`): they ignore Ctrl-C (the
terminal's reaches the whole process group; only the client acts on it) and run at yore's
thread defaults, then import yore's core before their first cell."""

from ..runtime import ignore_interrupts_in_sweep_workers, use_thread_defaults

ignore_interrupts_in_sweep_workers()
use_thread_defaults()
