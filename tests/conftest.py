"""Session-wide test setup.

Several tests interrupt a running step or a child `yore` process with Ctrl-C (SIGINT) and wait
for it to stop. A shell starts a background job (`make test &`, `nohup`, some CI runners) with
SIGINT ignored; Python then leaves it ignored, `_thread.interrupt_main()` does nothing, children
inherit the ignored signal, and those tests would wait forever on a step that cannot end. The
tests are about yore's handling of Ctrl-C, so they run with Python's own: restored here, once,
before any test (children started afterwards get the default disposition, which their Python
turns into KeyboardInterrupt again).
"""

import signal

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
