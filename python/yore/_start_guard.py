"""The `yore` command's Ctrl-C while the package itself is being imported: the one thing
importing yore ever sets, and only when the import is the command's own (its script, or
``python -m yore`` as the interpreter's module). Uses only modules the interpreter has already
loaded (``_signal``, ``os``, ``sys``): ``import signal`` alone takes milliseconds, and a Ctrl-C
landing in them printed Python's traceback (seen with ``python -m yore`` on a busy machine)."""

import _signal
import os
import sys


def interrupted(number, frame):  # pragma: no cover - exits the process
    os.write(2, b"yore: interrupted\n")
    os._exit(130)


def is_command_import() -> bool:
    """The process is the `yore` command: its script (named ``yore``), or the interpreter's
    module is yore (its first ``-m`` or ``-c`` is ``-m yore``)."""
    if sys.argv and os.path.basename(sys.argv[0]) == "yore":
        return True
    original = list(getattr(sys, "orig_argv", []))[1:]
    first = next((k for k, a in enumerate(original) if a in ("-m", "-c")), None)
    return first is not None and original[first : first + 2] == ["-m", "yore"]


def guard() -> None:
    """Ctrl-C ends the process with one line and exit 130 (`yore.runtime.start_command` takes
    over), if Python's own handling is in place and this is the main thread."""
    if _signal.getsignal(_signal.SIGINT) is not _signal.default_int_handler:
        return
    try:
        _signal.signal(_signal.SIGINT, interrupted)
    except ValueError:  # not the main thread
        pass
