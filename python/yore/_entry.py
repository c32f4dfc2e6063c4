"""The `yore` command's entry point: its script (``yore = "yore._entry:command"``) and
``python -m yore``. Imports nothing heavy itself, so that its Ctrl-C handling is in place
before the rest of yore loads."""

from .runtime import ignore_interrupts_in_sweep_workers, start_command

# A sweep's worker started from the `yore` command imports this module first (the command's
# script is its main module): it ignores Ctrl-C from here on (yore.runtime).
ignore_interrupts_in_sweep_workers()


def command() -> int:
    """The `yore` command: Ctrl-C while it starts is one line (`yore.runtime.start_command`),
    threads at yore's defaults (`yore.runtime.use_thread_defaults`; ``--threads`` overrides
    them), then `yore.cli.main`."""
    start_command()
    from .cli import main
    from .runtime import use_thread_defaults

    use_thread_defaults()
    return main()
