"""The BLAS that CHOLMOD calls, on the kernels this CPU runs.

CHOLMOD's supernodal factorization (≈ 90 % of an implicit step) spends its time in the dense
kernels of whatever ``libblas.so.3`` the system resolves; on Debian that is OpenBLAS, which picks
its kernels once, when it loads, from the CPU's family and model. Its tables lag the hardware:
Debian 12's OpenBLAS 0.3.21 runs a family-6, extended-model-12 Xeon (Emerald Rapids, AVX-512) on
its Prescott (SSE3) kernels, a fifth of the machine's dense rate. So ``import yore``, before the
core (and with it the BLAS) loads:

1. reads what the CPU and the OS run (`yore._cpu`: CPUID and XCR0, no BLAS involved);
2. asks a short child process which kernel OpenBLAS would pick on its own (the only honest way:
   the choice happens once per process, inside the library);
3. when that kernel is of a lower tier (SSE < AVX < AVX2 < AVX-512) than the CPU runs, sets
   ``OPENBLAS_CORETYPE`` to OpenBLAS's kernel of the CPU's tier (SkylakeX, Haswell or
   Sandybridge) for the load, and takes it out of the environment again afterwards.

A user's ``OPENBLAS_CORETYPE`` always wins, unless it names kernels the CPU cannot run: OpenBLAS
does not check (it would die of SIGILL at the first multiply), so yore then says so in one
warning line and loads the best kernel the CPU does run. `report()` (``yore info``, every
benchmark's JSON, the viewer's panel) says which kernel is in use and who chose it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from dataclasses import dataclass

__all__ = [
    "BlasWarning",
    "KernelChoice",
    "KERNEL_NEEDS",
    "TIER_KERNELS",
    "decide",
    "best_kernel",
    "kernel_tier",
    "thread_setting_problems",
    "report",
]

#: The environment variable OpenBLAS reads its kernel from, once, when it loads.
CORETYPE = "OPENBLAS_CORETYPE"

#: The thread settings OpenBLAS and OpenMP read when they load.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")

_AVX512 = frozenset({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"})

#: OpenBLAS's x86-64 kernel sets by the names ``OPENBLAS_CORETYPE`` takes (lowercase; OpenBLAS
#: compares without case) and the extensions their code uses. The 32-bit names load Prescott's
#: kernels on x86-64. SapphireRapids and Cooperlake add bf16 kernels to SkylakeX's.
KERNEL_NEEDS = {
    **{
        name: frozenset({"sse3"})
        for name in (
            "katmai",
            "coppermine",
            "northwood",
            "banias",
            "athlon",
            "prescott",
            "opteron_sse3",
            "barcelona",
        )
    },
    "opteron": frozenset(),
    **{name: frozenset({"ssse3"}) for name in ("core2", "atom", "bobcat", "nano")},
    "penryn": frozenset({"sse4_1"}),
    "dunnington": frozenset({"sse4_1"}),
    "nehalem": frozenset({"sse4_2"}),
    "sandybridge": frozenset({"avx"}),
    "bulldozer": frozenset({"avx", "fma4"}),
    "piledriver": frozenset({"avx", "fma", "fma4"}),
    "steamroller": frozenset({"avx", "fma", "fma4"}),
    "excavator": frozenset({"avx2", "fma", "fma4"}),
    "haswell": frozenset({"avx2", "fma"}),
    "zen": frozenset({"avx2", "fma"}),
    "skylakex": _AVX512,
    "cooperlake": _AVX512 | {"avx512_bf16"},
    "sapphirerapids": _AVX512 | {"avx512_bf16"},
}

#: OpenBLAS's kernel for each tier of vector width, best first: what yore sets.
TIER_KERNELS = (
    ("SkylakeX", _AVX512),
    ("Haswell", frozenset({"avx2", "fma"})),
    ("Sandybridge", frozenset({"avx"})),
)


def kernel_tier(name) -> int:
    """The vector tier of an OpenBLAS kernel name for double-precision multiplies: 3 AVX-512,
    2 AVX2, 1 AVX, 0 SSE or unknown."""
    needs = KERNEL_NEEDS.get(str(name or "").strip().lower(), frozenset())
    if _AVX512 <= needs:
        return 3
    if "avx2" in needs:
        return 2
    return 1 if "avx" in needs else 0


def best_kernel(extensions) -> str | None:
    """OpenBLAS's kernel of the widest tier the extensions run, or None below AVX."""
    have = set(extensions)
    return next((name for name, needs in TIER_KERNELS if needs <= have), None)


class BlasWarning(RuntimeWarning):
    """A BLAS setting yore could not honour (a kernel the CPU cannot run, a thread count no
    machine runs), or a BLAS loaded before yore on slow kernels."""


@dataclass(frozen=True)
class KernelChoice:
    """What `decide` chose: `coretype` is the value to put in ``OPENBLAS_CORETYPE`` for the
    load (None: leave the environment as it is); `chosen_by` is "user", "yore" or "openblas";
    `warning` is the one line to show, if any."""

    coretype: str | None
    chosen_by: str
    warning: str | None = None


def decide(extensions, requested, native) -> KernelChoice:
    """Chooses the kernels of the BLAS about to load.

    `extensions`: the CPU's usable extensions (`yore._cpu.cpu_features().extensions`);
    `requested`: the user's ``OPENBLAS_CORETYPE`` (None when unset); `native`: the kernel
    OpenBLAS picks by itself on this CPU (None when unknown, "" when the BLAS is not OpenBLAS).
    Pure: tested with made-up CPUs."""
    have = frozenset(extensions)
    best = best_kernel(have)
    if requested is not None:
        needs = KERNEL_NEEDS.get(requested.strip().lower())
        if needs is None or needs <= have:
            return KernelChoice(None, "user")  # OpenBLAS itself refuses names it does not know
        instead = best or "Prescott"
        return KernelChoice(
            instead,
            "yore",
            (
                f"{CORETYPE}={requested} needs {', '.join(sorted(needs - have))}, which this CPU "
                f"does not run (it would stop with SIGILL); yore loads the {instead} kernels "
                f"instead: unset {CORETYPE} or set it to {instead}"
            ),
        )
    if best is None or native == "":
        return KernelChoice(None, "openblas")
    if native is not None and kernel_tier(native) >= kernel_tier(best):
        return KernelChoice(None, "openblas")
    return KernelChoice(best, "yore")


def thread_setting_problems(environ) -> dict:
    """The thread variables (``OPENBLAS_NUM_THREADS``, ``GOTO_NUM_THREADS``,
    ``OMP_NUM_THREADS``) no machine runs, as {name: (value to use instead or None to drop it,
    the warning line)}: not a whole number ≥ 1, or more than yore's limit of threads (libgomp
    aborts the process when it cannot start them)."""
    from .checks import MAX_THREADS

    problems = {}
    for name in THREAD_VARIABLES:
        text = environ.get(name)
        if text is None:
            continue
        first = text.split(",")[0].strip()  # OMP_NUM_THREADS may list one count per level
        try:
            count = int(first)
        except ValueError:
            count = None
        if count is None or count < 1:
            problems[name] = (
                None,
                f"{name}={text!r} is not a number of threads (a whole "
                f"number from 1 to {MAX_THREADS}); yore ignores it",
            )
        elif count > MAX_THREADS:
            problems[name] = (
                str(MAX_THREADS),
                f"{name}={text} is more threads than yore "
                f"runs (at most {MAX_THREADS}); yore uses "
                f"{MAX_THREADS}",
            )
    return problems


# -- at import -------------------------------------------------------------------------------

_PROBE = r"""
import ctypes, json
out = {}
try:
    library = ctypes.CDLL("libblas.so.3")
except OSError as error:
    out["error"] = str(error)
else:
    try:
        corename = library.openblas_get_corename
    except AttributeError:
        out["corename"] = ""
    else:
        corename.restype = ctypes.c_char_p
        out["corename"] = corename().decode(errors="replace")
print(json.dumps(out))
"""


def native_kernel() -> str | None:
    """The kernel OpenBLAS picks by itself on this machine, asked of a child process that loads
    ``libblas.so.3`` with ``OPENBLAS_CORETYPE`` unset: "" when that library is not OpenBLAS,
    None when the question failed."""
    environment = {key: value for key, value in os.environ.items() if key != CORETYPE}
    environment.update(OPENBLAS_NUM_THREADS="1", OPENBLAS_VERBOSE="0")
    try:
        answer = subprocess.run(
            [sys.executable, "-S", "-E", "-c", _PROBE],
            env=environment,
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
        return json.loads(answer.stdout.strip().splitlines()[-1]).get("corename")
    except (OSError, ValueError, IndexError, subprocess.SubprocessError):
        return None


def _loaded_blas() -> list:
    """Paths of the system BLAS mapped into this process (/proc/self/maps): the
    ``libblas.so.3`` CHOLMOD calls and the library behind it, not a wheel's bundled copy
    (numpy's lives in ``numpy.libs`` under another name and serves numpy alone)."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            paths = {line.split()[-1] for line in maps if "/" in line}
    except OSError:
        return []
    prefixes = ("libblas.so", "libopenblas", "libblis", "libmkl_rt")
    return sorted(
        path
        for path in paths
        if os.path.basename(path).startswith(prefixes)
        and "site-packages" not in path
        and ".libs/" not in path
    )


def _system_blas_loaded() -> bool:
    return any(os.path.basename(path).startswith("libblas.so") for path in _loaded_blas())


_STATE = {
    "chosen_by": "openblas",
    "requested": None,
    "set_by_yore": None,
    "note": "",
    "in_command": False,
}


def mark_command() -> None:
    """This process is the `yore` command: warnings are ``yore: warning:`` lines (called by
    `yore.runtime.start_command`)."""
    _STATE["in_command"] = True


def in_command() -> bool:
    return _STATE["in_command"]


def _loaded_kernel() -> str:
    """OpenBLAS's kernel in this process (``openblas_get_corename`` of the loaded library), ""
    when the loaded BLAS is not OpenBLAS or none is loaded yet."""
    import ctypes

    for path in _loaded_blas():
        try:
            corename = ctypes.CDLL(path).openblas_get_corename
        except (OSError, AttributeError):
            continue
        corename.restype = ctypes.c_char_p
        return (corename() or b"").decode(errors="replace")
    return ""


def _stacklevel_outside_yore() -> int:
    """The `warnings.warn` stacklevel, for its caller (`_say`), of the first frame outside yore
    and importlib: the program's line that loaded the core, whichever module it went through.
    Counted as `warnings` counts, which skips importlib's bootstrap frames."""
    package = os.path.dirname(os.path.abspath(__file__))

    def bootstrap(frame):
        name = frame.f_code.co_filename
        return "importlib" in name and "_bootstrap" in name

    frame, level = sys._getframe(1), 1
    while frame is not None and (
        frame.f_code.co_filename.startswith(package) or "importlib" in frame.f_code.co_filename
    ):
        frame = frame.f_back
        while frame is not None and bootstrap(frame):
            frame = frame.f_back
        level += 1
    return level


def _say(message, in_command) -> None:
    """One warning line: ``yore: warning: ...`` for the command, a BlasWarning for a program."""
    if in_command:
        print(f"yore: warning: {message}", file=sys.stderr, flush=True)
    else:
        warnings.warn(message, BlasWarning, stacklevel=_stacklevel_outside_yore())


def prepare(in_command=False) -> None:
    """Before the core loads: fixes thread settings no machine runs and chooses the BLAS
    kernels (`decide`), setting ``OPENBLAS_CORETYPE`` for the load where that pays."""
    for name, (value, message) in thread_setting_problems(os.environ).items():
        _say(message, in_command)
        if value is None:
            del os.environ[name]
        else:
            os.environ[name] = value
    requested = os.environ.get(CORETYPE)
    _STATE["requested"] = requested
    if _system_blas_loaded():
        _STATE["note"] = "loaded before yore"
        return
    from ._cpu import cpu_features

    extensions = cpu_features().extensions
    if not extensions:  # not x86-64: OpenBLAS's own choice
        return
    native = None
    if requested is None and best_kernel(extensions) is not None:
        native = native_kernel()
    choice = decide(extensions, requested, native)
    _STATE["chosen_by"] = choice.chosen_by
    if choice.warning:
        _say(choice.warning, in_command)
    if choice.coretype is not None:
        os.environ[CORETYPE] = choice.coretype
        _STATE["set_by_yore"] = choice.coretype


def finish(in_command=False) -> None:
    """After the core loaded: a kernel yore chose for an unset ``OPENBLAS_CORETYPE`` leaves
    the environment again (child processes decide for themselves; a library loaded later keeps
    its own choice). A replacement of a user's unrunnable value stays: it keeps children alive.
    A BLAS that was loaded before yore, on narrower kernels than the CPU runs, is one warning
    line that says how to start faster."""
    if _STATE["requested"] is None and _STATE["set_by_yore"] is not None:
        os.environ.pop(CORETYPE, None)
    if _STATE["note"] and _STATE["requested"] is None:
        info = report()
        if (
            info["kernel"]
            and info["cpu_kernel"]
            and kernel_tier(info["kernel"]) < kernel_tier(info["cpu_kernel"])
        ):
            _say(
                f"the BLAS that CHOLMOD calls was loaded before yore, on OpenBLAS's "
                f"{info['kernel']} kernels; this CPU runs {info['cpu_kernel']}: set "
                f"{CORETYPE}={info['cpu_kernel']} before starting Python for faster "
                f"implicit steps",
                in_command,
            )


def report() -> dict:
    """The BLAS in use: `library` (paths mapped), `kernel` (OpenBLAS's core name, "" for another
    BLAS), `chosen_by` ("user", "yore" or "openblas"), `cpu_kernel` (the widest kernel this CPU
    runs, None below AVX), `tier` ("AVX-512", "AVX2", "AVX" or "SSE" of the kernel in use),
    `requested` (the user's OPENBLAS_CORETYPE) and `note`. Before yore's core has loaded (and
    with it the BLAS) the kernel is "" and the note says so."""
    from ._cpu import cpu_features

    kernel = _loaded_kernel()
    chosen_by = _STATE["chosen_by"]
    if _STATE["note"]:
        chosen_by = "user" if _STATE["requested"] is not None else "openblas"
    note = _STATE["note"]
    if not note and "yore._native" not in sys.modules:
        note = "yore's core has not loaded the BLAS yet"
    return {
        "library": _loaded_blas(),
        "kernel": kernel,
        "chosen_by": chosen_by,
        "cpu_kernel": best_kernel(cpu_features().extensions),
        "tier": ("SSE", "AVX", "AVX2", "AVX-512")[kernel_tier(kernel)],
        "requested": _STATE["requested"],
        "note": note,
    }


def describe(info=None) -> str:
    """One line for people: "SkylakeX kernels (AVX-512), chosen by yore"."""
    info = report() if info is None else info
    if not info["kernel"]:
        return "not OpenBLAS (kernels of its own choice)"
    line = f"{info['kernel']} kernels ({info['tier']}), chosen by {info['chosen_by']}"
    if info["cpu_kernel"] and kernel_tier(info["kernel"]) < kernel_tier(info["cpu_kernel"]):
        line += f"; this CPU runs {info['cpu_kernel']}"
    return line + (f"; {info['note']}" if info["note"] else "")
