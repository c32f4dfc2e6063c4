"""The ``yore`` command.

    yore run SCENE.toml [-o OUT] [--set KEY=VALUE ...] [--until SECONDS] [--overwrite] [--quiet]
    yore run --resume OUT/state.npz [-o OUT2] [--until SECONDS] [--quiet]
    yore check SCENE.toml [--set KEY=VALUE ...]
    yore demo [-o OUT] [--overwrite] [--quiet]
    yore render FRAME|RUN_DIR [-o OUT] [--width W] [--height H] [--color-by none|expansion|wrinkles]
                [--animation gif|mp4|none] [--no-pictures] [--eye X Y Z] [--target X Y Z]
                [--up X Y Z] [--fov DEGREES] [--framing cloth|run]
    yore view SCENE.toml|STATE.npz [--set KEY=VALUE ...] [--headless --stroke-px "x,y x,y ..."
              [--at T] [--until T] --screenshot PNG] [--width W] [--height H] [stroke options]
    yore sweep SWEEP.toml [-o OUT] [--scheduler tcp://host:8786] [--workers N] [--overwrite]
    yore sweep --resume OUT [--scheduler ...] [--workers N]
    yore sweep plot OUT --x DIM --y DIM --value NAME [--select DIM=VALUE ...] [-o PNG]
    yore info [--threads N]
    yore --version
Every command takes --threads N (the threads of the core's loops and of BLAS, see
`yore.set_num_threads`; default: the scene's [simulation] threads, else the machine's cores).

Exit codes: 0 success; 1 the run failed (it diverged, or a stroke missed at its time; the
state before the failure is saved); 2 bad input (command line, scene file, missing file),
reported before anything runs; 130 interrupted (a run saves its state first, so
``yore run --resume`` continues it exactly). Errors are one line on stderr, starting
with "yore: error:".
"""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["main"]

from .cli_parser import (  # noqa: F401  (the exit codes and the parser are cli's API)
    EXIT_BAD_INPUT,
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_OK,
    scene_overrides,
    build_parser,
)
from .cli_view import check_view_numbers, view_command


def demo_scene_text() -> str:
    """The demo's scene file (the same text as examples/hanging.toml)."""
    from .runs import demo_scene_text as text

    return text()


def _report(summary, out, quiet):
    if quiet:
        return
    counters = summary["counters"]
    print(
        f"simulated {summary['time']:.3f} s in {summary['steps']} {summary['integrator']} "
        f"steps of {summary['dt']:.4g} s ({summary['wall_seconds']:.1f} s wall)"
    )
    for stroke in summary["strokes"]:
        print(
            f"stroke {stroke['stroke']} at t = {stroke['time']:.3f} s: "
            f"{stroke['faces_split']} faces split, {stroke['vertices_added']} vertices added"
        )
    if counters.get("analyses") is not None:
        print(
            f"symbolic analyses: {counters['analyses']}, factorizations: "
            f"{counters.get('factorizations')}"
        )
    if counters.get("energy_gain"):  # the growth check's measure (docs/integrators.md)
        print(f"largest energy rise above its lowest: {counters['energy_gain']:.3g} J")
    outputs = summary["outputs"]
    where = {
        "frames": "frames",
        "pvd": "ParaView collection",
        "before_after": "before/after",
        "demo": "no stroke / paper / yore",
        "last": "last frame picture",
        "animation": "animation",
        "summary": "summary",
        "state": "state (yore run --resume)",
    }
    for key, label in where.items():
        if key in outputs:
            print(f"{label + ':':28s}{(out / outputs[key]).resolve()}")


def _info(arguments):
    from . import blas
    from .runtime import build_info

    info = build_info()
    width = max(len(key) for key in info)
    for key in sorted(info):
        print(f"{key:<{width}}  {info[key]}")
    print(f"{'BLAS':<{width}}  {blas.describe()}")


def _run(arguments):
    from .runs import load_scene, resume_run, run_scene

    if arguments.resume is not None:
        if arguments.scene is not None or arguments.overrides:
            raise ValueError("--resume continues a saved run: give no scene file and no --set")
        summary = resume_run(
            arguments.resume,
            out=arguments.out,
            until=arguments.until,
            quiet=arguments.quiet,
            render=not arguments.no_render,
            overwrite=arguments.overwrite,
            threads=arguments.threads,
            allow_long=arguments.allow_long,
        )
        out = arguments.out or arguments.resume.parent
    else:
        if arguments.scene is None:
            raise ValueError("give a scene file (yore run SCENE.toml) or --resume STATE")
        scene = load_scene(arguments.scene, overrides=scene_overrides(arguments))
        out = arguments.out or Path("yore-out") / arguments.scene.stem
        summary = run_scene(
            scene,
            out,
            until=arguments.until,
            quiet=arguments.quiet,
            render=not arguments.no_render,
            overwrite=arguments.overwrite,
            threads=arguments.threads,
            allow_long=arguments.allow_long,
        )
    _report(summary, Path(out), arguments.quiet)


def _check(arguments):
    from .runs import load_scene

    from .checks import MAX_STEPS
    from .runs.runner import check_scene

    scene = load_scene(arguments.scene, overrides=scene_overrides(arguments))
    sim, steps = check_scene(scene, allow_long=True)
    long = f" (more than {MAX_STEPS}: yore run needs --allow-long)" if steps > MAX_STEPS else ""
    print(
        f"{arguments.scene}: OK ({sim.cloth.vertex_count} vertices, {sim.integrator}, "
        f"dt = {sim.dt:.4g} s, {steps} steps{long}, {len(scene.data.strokes)} stroke(s))"
    )


def _demo(arguments):
    from .runs import run_demo

    summary = run_demo(
        arguments.out,
        overrides=scene_overrides(arguments),
        quiet=arguments.quiet,
        overwrite=arguments.overwrite,
        threads=arguments.threads,
    )
    _report(summary, arguments.out, arguments.quiet)


def _render(arguments):
    from .viz.pictures import render_frame, render_run

    path = arguments.path
    check_view_numbers(arguments)
    if path.is_dir():
        written = render_run(
            path,
            pictures=not arguments.no_pictures,
            animation=None if arguments.animation == "none" else arguments.animation,
            color_by=arguments.color_by,
            width=arguments.width,
            height=arguments.height,
            out=arguments.out,
            eye=arguments.eye,
            target=arguments.target,
            up=arguments.up,
            fov_degrees=arguments.fov,
            framing=arguments.framing,
            quiet=arguments.quiet,
        )
        base = path if arguments.out is None else Path(".")
        if not arguments.quiet:
            for name, file in written.items():
                print(f"{name + ':':14s}{(base / file).resolve()}")
    else:
        written = render_frame(
            path,
            out=arguments.out,
            width=arguments.width,
            height=arguments.height,
            color_by=arguments.color_by,
            eye=arguments.eye,
            target=arguments.target,
            up=arguments.up,
            fov_degrees=arguments.fov,
        )
        if not arguments.quiet:
            print(f"picture:      {written.resolve()}")


def _sweep(arguments):
    try:
        _sweep_or_resume(arguments)
    except KeyboardInterrupt:
        # the cells finished so far are on disk and in results.nc (written on the way out)
        out = arguments.resume or arguments.out or Path("yore-out") / arguments.sweep.stem
        if not (Path(out) / "sweep.json").is_file():  # before the folder was made
            raise KeyboardInterrupt(
                "interrupted before the sweep started; nothing was written"
            ) from None
        raise KeyboardInterrupt(
            f"interrupted; the finished cells are in {out}, "
            f"`yore sweep --resume {out}` runs the rest"
        ) from None


def _sweep_or_resume(arguments):
    from .sweep import resume, run

    if arguments.resume is not None:
        if arguments.sweep is not None:
            raise ValueError("--resume continues a sweep folder: give no sweep file")
        results = resume(
            arguments.resume,
            scheduler=arguments.scheduler,
            workers=arguments.workers,
            quiet=arguments.quiet,
            connect_timeout=arguments.connect_timeout,
        )
    else:
        if arguments.sweep is None:
            raise ValueError("give a sweep file (yore sweep SWEEP.toml) or --resume OUT")
        out = arguments.out or Path("yore-out") / arguments.sweep.stem
        results = run(
            arguments.sweep,
            out,
            scheduler=arguments.scheduler,
            workers=arguments.workers,
            quiet=arguments.quiet,
            overwrite=arguments.overwrite,
            connect_timeout=arguments.connect_timeout,
        )
    if not arguments.quiet:
        counts = ", ".join(f"{n} {status}" for status, n in results.counts().items())
        print(f"cells: {counts}")
        print(f"results:      {(results.out / 'results.nc').resolve()}")


def _sweep_plot(arguments):
    from .sweep import heat_map

    select = {}
    for text in arguments.select:
        name, equals, value = text.partition("=")
        if not equals or not name:
            raise ValueError(f"--select takes DIM=VALUE, got {text!r}")
        select[name] = value
    path = heat_map(
        arguments.out,
        arguments.x,
        arguments.y,
        arguments.value,
        select=select,
        path=arguments.output,
    )
    print(f"picture:      {path.resolve()}")


def _view(arguments):
    view_command(arguments)


def main(argv=None) -> int:
    """Runs the command line in this process, as it is (no signal handler or thread setting of
    its own: `yore._entry.command` is the command); returns the exit code (see the module
    docstring)."""
    import warnings

    from .runtime import end_command

    shown = warnings.formatwarning
    # a warning is one line that says what happened, not the source line that warned
    warnings.formatwarning = _one_line_warning
    try:
        return _main(argv)
    except KeyboardInterrupt:
        # it landed after _main's own handling (in its last lines) and before end_command
        print("yore: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        end_command()  # the `yore` command ignores a Ctrl-C in its shutdown (see yore.runtime)
        warnings.formatwarning = shown


def _one_line_warning(message, category, filename, lineno, line=None):
    return f"yore: warning: {' '.join(str(message).split())}\n"


def _main(argv) -> int:
    from .runtime import end_command_start

    try:
        arguments = _parse(argv)
        from .runs import RunError

        # Ctrl-C is main's to handle from here (see yore.runtime); until now the command's
        # guard ended the process with one line, as nothing had run
        end_command_start()
    except KeyboardInterrupt:  # (main() called in-process, without the guard): nothing ran yet
        print("yore: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED

    handlers = {
        "run": _run,
        "check": _check,
        "demo": _demo,
        "render": _render,
        "view": _view,
        "sweep": _sweep,
        "sweep-plot": _sweep_plot,
        "info": _info,
    }
    try:
        if getattr(arguments, "threads", None) is not None:
            from . import set_num_threads

            set_num_threads(arguments.threads)
        handlers[arguments.command](arguments)
    except KeyboardInterrupt as interruption:
        _report_interruption(interruption)
        return EXIT_INTERRUPTED
    except RunError as error:
        _fail(error)
        return EXIT_FAILED
    except (ValueError, OSError) as error:
        if _interrupted(error):
            print("yore: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        _fail(error)
        return EXIT_BAD_INPUT
    except Exception as error:
        if not _interrupted(error):
            raise
        # a Ctrl-C inside an import (dask's, on a sweep's start-up) leaves a half-initialised
        # module whose next use fails with a NameError or AttributeError: still an interruption
        print("yore: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_OK


def _parse(argv):
    """The command line's arguments (argparse's exit, code 2, on a wrong one)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:2] == ["sweep", "plot"]:
        argv = ["sweep-plot", *argv[2:]]
    parser = build_parser()
    arguments, unknown = parser.parse_known_args(argv)
    if unknown:  # named by the command's parser, whose --help lists its options
        commands = next(a for a in parser._actions if a.dest == "command").choices
        command = commands.get(getattr(arguments, "command", None), parser)
        command.error(f"unrecognized arguments: {' '.join(unknown)}")
    return arguments


def _report_interruption(interruption) -> None:
    """The one line a Ctrl-C ends a command with (and how to resume a run it stopped)."""
    state = getattr(interruption, "state_path", None)
    print(
        f"yore: {interruption}; `yore run --resume {state}` continues"
        if state
        else f"yore: {interruption}"
        if str(interruption)
        else "yore: interrupted",
        file=sys.stderr,
    )


def _interrupted(error) -> bool:
    """Whether a KeyboardInterrupt is in the chain of exceptions that led to ``error``."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def _fail(error):
    message = " ".join(str(error).split())  # one line, whatever the message holds
    print(f"yore: error: {message}", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
