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

import argparse
import math
import sys
from pathlib import Path

__all__ = ["main"]

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line and exit code 2 (as argparse does)."""

    def error(self, message):
        # the command as typed ("yore sweep plot", "yore run"), whose --help says more
        self.exit(EXIT_BAD_INPUT, f"yore: error: {message} (see `{self.prog} --help`)\n")


def _parser():
    from . import __version__

    parser = _Parser(
        prog="yore",
        description="Cloth simulation with stroke-driven wrinkles "
        "(Shi & Saito): run scene files, render pictures.",
    )
    parser.add_argument("--version", action="version", version=f"yore {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    commands.required = True
    _add_run(commands)
    _add_check(commands)
    _add_demo(commands)
    _add_render(commands)
    _add_view(commands)
    _add_sweep(commands)
    _add_sweep_plot(commands)
    _add_info(commands)
    return parser


def _add_run(commands):
    """`yore run`: a scene file, or --resume a run."""
    run = commands.add_parser(
        "run",
        help="run a scene file (or resume a run)",
        description="Run a TOML scene file, writing frames, a ParaView "
        "collection, summary.json, state.npz and pictures into OUT.",
    )
    run.add_argument("scene", nargs="?", type=Path, help="the scene file (.toml)")
    run.add_argument(
        "-o",
        "--out",
        type=Path,
        help="output folder (default: yore-out/SCENE; with --resume: the state's folder)",
    )
    run.add_argument(
        "--resume",
        type=Path,
        metavar="STATE",
        help="continue the run saved in STATE (a run's state.npz)",
    )
    run.add_argument(
        "--until",
        type=float,
        metavar="SECONDS",
        help="stop at this simulated time instead of the scene's duration",
    )
    _add_set(run)
    _add_overwrite(run)
    run.add_argument(
        "--no-render",
        action="store_true",
        help="skip the pictures and animation the scene asks for",
    )
    run.add_argument(
        "--allow-long", action="store_true", help="allow a run of more than 100 000 000 steps"
    )
    _add_common(run)


def _add_check(commands):
    """`yore check`: a scene file checked and built, not run."""
    check = commands.add_parser(
        "check",
        help="check a scene file without running it",
        description="Check a scene file (keys, types, values, vertex "
        "selections, strokes that can be tried at t = 0) and build "
        "its simulation, without running it.",
    )
    check.add_argument("scene", type=Path, help="the scene file (.toml)")
    _add_set(check)
    _add_common(check, quiet=False)


def _add_demo(commands):
    """`yore demo`: the paper's hanging cloth three ways."""
    demo = commands.add_parser(
        "demo",
        help="the paper's hanging cloth: no stroke, the paper's stroke, yore's stroke",
        description="The paper's hanging-cloth experiment three ways: "
        "yore's stroke (examples/hanging.toml: frames, pictures and an "
        "animation in OUT), the paper's operation (OUT/paper) and the "
        "cloth without a stroke (OUT/no-stroke, OUT/paper-no-stroke); "
        "OUT/demo.png shows them side by side, summary.json's demo "
        "table holds their wrinkle measures and spike indices.",
    )
    demo.add_argument(
        "-o", "--out", type=Path, default=Path("yore-out"), help="output folder (default: yore-out)"
    )
    _add_set(demo)
    _add_overwrite(demo)
    _add_common(demo)


def _add_render(commands):
    """`yore render`: pictures of a frame or a run."""
    from .options import ANIMATION_FORMATS, IMAGE_HEIGHT, IMAGE_WIDTH, RENDER_ANIMATION

    render = commands.add_parser(
        "render",
        help="pictures of a frame or a run",
        description="PNG pictures of a frame file, or of a run folder "
        "(before/after side by side, last frame, animation).",
    )
    render.add_argument("path", type=Path, help="a frame file or a run folder")
    render.add_argument(
        "-o",
        "--out",
        type=Path,
        help="PNG file (frame) or folder (run); default: next to the frame, or the run folder",
    )
    render.add_argument(
        "--width",
        type=int,
        help=f"image width, pixels (default: the scene's [camera] width, {IMAGE_WIDTH})",
    )
    render.add_argument(
        "--height",
        type=int,
        help=f"image height, pixels (default: the scene's [camera] height, {IMAGE_HEIGHT})",
    )
    render.add_argument(
        "--color-by",
        choices=("none", "expansion", "wrinkles"),
        default=None,
        help="colour by rest-length expansion or signed wrinkle height, with a "
        "colour bar (default: the scene's [output] color_by, else none)",
    )
    render.add_argument(
        "--animation",
        choices=ANIMATION_FORMATS,
        default=RENDER_ANIMATION,
        help=f"animation of a run's frames (default {RENDER_ANIMATION}; mp4 needs ffmpeg)",
    )
    render.add_argument("--no-pictures", action="store_true", help="a run: only the animation")
    _add_eye_and_target(
        render, "point the camera looks at, m (default: the scene's, else the cloth's centre)"
    )
    _add_view_options(render)
    render.add_argument(
        "--framing",
        choices=("cloth", "run"),
        default=None,
        help="cloth: each picture framed tightly on the cloth it shows, the "
        "animation's camera follows the cloth; run: one camera for every frame "
        "(default: the scene's [output] framing, else cloth)",
    )
    _add_common(render)


def _add_view(commands):
    """`yore view`: the live viewer, or headless."""
    view = commands.add_parser(
        "view",
        help="watch a simulation live and draw strokes with "
        "the mouse (or headless, strokes in pixels)",
        description="Open a window (polyscope) in which the simulation "
        "of a scene file or a saved state runs live; press D (or the "
        "panel's button) to draw a stroke with the left mouse button. "
        "With --headless the same code runs without a window: "
        "--stroke-px draws a stroke through pixels of the view at --at, "
        "--until runs on, --screenshot saves the view.",
    )
    view.add_argument("source", type=Path, help="a scene file (.toml) or a state (.npz)")
    _add_set(view)
    _add_view_headless(view)
    _add_view_camera(view)
    _add_view_options(view)
    _add_view_stroke(view)
    _add_common(view)


def _add_view_headless(view):
    """`yore view`'s options of a run without a window."""
    view.add_argument(
        "--headless",
        action="store_true",
        help="no window: EGL off-screen rendering (over SSH, in scripts, tests)",
    )
    view.add_argument(
        "--stroke-px",
        dest="stroke_px",
        action="append",
        default=[],
        metavar='"x,y x,y ..."',
        help="headless: a stroke through these pixels "
        "of the view (x right, y down, from the top-left pixel's centre); may be "
        "given several times",
    )
    view.add_argument(
        "--at",
        type=float,
        metavar="SECONDS",
        help="headless: simulated time at which the strokes are drawn (default: the start)",
    )
    view.add_argument(
        "--until",
        type=float,
        metavar="SECONDS",
        help="headless: run until this simulated time (default: --at, or the start)",
    )
    view.add_argument(
        "--screenshot",
        type=Path,
        metavar="PNG",
        help="save the view at the end as this PNG (headless: required)",
    )
    view.add_argument(
        "--panel",
        action="store_true",
        help="headless: draw the window's panels (controls, statistics) into the screenshot",
    )


def _add_view_camera(view):
    """`yore view`'s picture size and camera."""
    from .options import IMAGE_HEIGHT, IMAGE_WIDTH

    view.add_argument(
        "--width",
        type=int,
        help="view width, pixels (default: the scene's "
        f"[camera] width, {IMAGE_WIDTH}; alone: the aspect ratio is kept)",
    )
    view.add_argument(
        "--height",
        type=int,
        help=f"view height, pixels (default: the scene's [camera] height, {IMAGE_HEIGHT})",
    )
    _add_eye_and_target(view, "point the camera looks at, m")


def _add_view_stroke(view):
    """`yore view`'s options of the strokes drawn."""
    from .options import GROWTH_MODES, STROKE_DEFAULTS

    view.add_argument(
        "--expansion",
        type=float,
        default=None,
        help=f"stroke expansion (default {STROKE_DEFAULTS['expansion']}, or the "
        "scene's "
        "first stroke's)",
    )
    view.add_argument(
        "--width-m",
        dest="stroke_width",
        type=float,
        default=None,
        metavar="METRES",
        help="stroke band width, m (default: the paper's, crossed faces only)",
    )
    view.add_argument(
        "--growth",
        choices=GROWTH_MODES,
        default=None,
        help=f"stroke growth mode (default {STROKE_DEFAULTS['growth']})",
    )
    view.add_argument("--refine", type=int, default=None, help="stroke refinement passes")
    view.add_argument(
        "--smooth",
        type=int,
        default=None,
        metavar="ITERATIONS",
        help="rest-length smoothing iterations after each stroke (default 0)",
    )


def _add_sweep(commands):
    """`yore sweep`: a parameter sweep on Dask."""
    sweep = commands.add_parser(
        "sweep",
        help="a parameter sweep on Dask (then `yore sweep plot OUT ...` for heat maps)",
        description="Run every cell of a sweep file (a base scene, "
        "axes over its keys) as a Dask task, on a local cluster or a "
        "scheduler's; results go to OUT/results.nc (xarray, NetCDF) as "
        "cells finish. `yore sweep plot OUT --x DIM --y DIM --value "
        "NAME` draws a heat map.",
    )
    sweep.add_argument("sweep", nargs="?", type=Path, help="the sweep file (.toml)")
    sweep.add_argument("-o", "--out", type=Path, help="output folder (default: yore-out/SWEEP)")
    sweep.add_argument(
        "--resume",
        type=Path,
        metavar="OUT",
        help="continue the sweep in OUT: run only the cells it does not hold",
    )
    sweep.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://host:8786 (default: a local cluster)",
    )
    sweep.add_argument(
        "--connect-timeout",
        type=float,
        metavar="SECONDS",
        default=10.0,
        help="seconds a --scheduler has to answer (default 10)",
    )
    sweep.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local worker processes, one thread each (default: the machine's cores)",
    )
    _add_overwrite(sweep)
    _add_common(sweep)  # --threads: this process's; every cell runs on one thread


def _add_sweep_plot(commands):
    """`yore sweep plot` (the parser's "sweep-plot"): a heat map."""
    plot = commands.add_parser(
        "sweep-plot",
        prog="yore sweep plot",
        help=argparse.SUPPRESS,
        description="A heat map of a recorded value over two dimensions of a sweep.",
    )
    plot.add_argument("out", type=Path, help="the sweep's folder")
    plot.add_argument("--x", required=True, metavar="DIM", help="dimension along x")
    plot.add_argument("--y", required=True, metavar="DIM", help="dimension along y")
    plot.add_argument(
        "--value",
        required=True,
        metavar="NAME",
        help="a recorded variable (e.g. wall_seconds, error_rms, newton_iterations)",
    )
    plot.add_argument(
        "--select",
        action="append",
        default=[],
        metavar="DIM=VALUE",
        help="fix another dimension at one of its values",
    )
    plot.add_argument(
        "-o", "--output", type=Path, metavar="PNG", help="picture file (default: OUT/VALUE_Y_X.png)"
    )
    _add_common(plot, quiet=False)


def _add_info(commands):
    """`yore info`: what yore runs on."""
    info = commands.add_parser(
        "info",
        help="versions, threads and the BLAS kernels in use",
        description="The versions yore was built with, its threads, the "
        "CPU's widest BLAS kernels and the ones in use, and who chose "
        "them (the user's OPENBLAS_CORETYPE, yore, or OpenBLAS itself).",
    )
    _add_common(info, quiet=False)


def _add_eye_and_target(parser, target_help):
    """`--eye` and `--target` of render and view (``target_help``: how each defaults)."""
    for name, help in (
        ("--eye", "camera position, m (default: the scene's, else fitted)"),
        ("--target", target_help),
    ):
        parser.add_argument(name, type=float, nargs=3, metavar=("X", "Y", "Z"), help=help)


def _add_view_options(parser):
    parser.add_argument(
        "--up",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="the world direction shown upwards (default: the scene's, else "
        "0 1 0); the ground plane lies across the axis nearest to it",
    )
    parser.add_argument(
        "--fov",
        type=float,
        metavar="DEGREES",
        help="vertical field of view, degrees (default: the scene's, else 35)",
    )


def _add_set(parser):
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene key, e.g. --set mesh.nx=9 "
        "--set simulation.duration=0.5 (VALUE is read as TOML)",
    )


def _add_overwrite(parser):
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the run OUT already holds (its frames, pictures, summary "
        "and state; nothing else); without it a folder holding another or an "
        "unfinished run is refused",
    )


def _add_common(parser, quiet=True):
    parser.add_argument(
        "--threads",
        type=int,
        metavar="N",
        help="threads of the core's loops and of BLAS (default: the scene's "
        "[simulation] threads, else the machine's cores)",
    )
    if quiet:
        parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no report")


def _overrides(arguments):
    from .runs import parse_override

    return dict(parse_override(text) for text in arguments.overrides)


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
        scene = load_scene(arguments.scene, overrides=_overrides(arguments))
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

    scene = load_scene(arguments.scene, overrides=_overrides(arguments))
    sim, steps = check_scene(scene, allow_long=True)
    long = f" (more than {MAX_STEPS}: yore run needs --allow-long)" if steps > MAX_STEPS else ""
    print(
        f"{arguments.scene}: OK ({sim.cloth.vertex_count} vertices, {sim.integrator}, "
        f"dt = {sim.dt:.4g} s, {steps} steps{long}, {len(scene.data['strokes'])} stroke(s))"
    )


def _demo(arguments):
    from .runs import run_demo

    summary = run_demo(
        arguments.out,
        overrides=_overrides(arguments),
        quiet=arguments.quiet,
        overwrite=arguments.overwrite,
        threads=arguments.threads,
    )
    _report(summary, arguments.out, arguments.quiet)


def _render(arguments):
    from .viz.pictures import render_frame, render_run

    path = arguments.path
    _check_view_numbers(arguments)
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


def _check_view_numbers(arguments):
    """Image sizes, field of view and vectors of render/view, checked before any work."""
    from .checks import check_image_size, check_vector

    for name in ("width", "height"):
        value = getattr(arguments, name, None)
        if value is not None:
            check_image_size(
                value if name == "width" else 1, value if name == "height" else 1, f"--{name}"
            )
    if arguments.fov is not None:
        from .camera import check_fov

        check_fov(arguments.fov, "--fov")
    for name in ("eye", "target", "up"):
        value = getattr(arguments, name, None)
        if value is not None:
            check_vector(value, f"--{name}") if name == "up" else None
            if not all(abs(v) < 1e12 for v in value):
                raise ValueError(f"--{name} must be 3 finite numbers, got {value}")


#: Smallest picture side with --panel (the panels are drawn into it; 1 px failed in OpenGL).
MIN_PANEL_SIDE = 16


def _view(arguments):
    if getattr(arguments, "panel", False):
        for name in ("width", "height"):
            value = getattr(arguments, name, None)
            if value is not None and value < MIN_PANEL_SIDE:
                raise ValueError(
                    f"--{name} must be at least {MIN_PANEL_SIDE} px with --panel, got {value}"
                )

    _check_view_numbers(arguments)
    _run_view(arguments, _overrides(arguments))


# -- yore view ------------------------------------------------------------------------------------
def _view_source(source, overrides):
    """(simulation, camera settings, first stroke's options) of a scene file or a state."""
    source = Path(source)
    if source.suffix.lower() == ".npz":
        if overrides:
            raise ValueError("--set changes a scene file; a state (.npz) takes none")
        from .state import load_state

        sim, metadata = load_state(source)
        settings = None
        overrides = metadata.get("overrides") if isinstance(metadata, dict) else None
        if (
            isinstance(metadata, dict)
            and isinstance(metadata.get("scene_text"), str)
            and (overrides is None or isinstance(overrides, dict))
        ):
            # a run's state: its scene's [camera] (a record that is not a run's is ignored)
            from .runs import load_scene

            try:
                settings = load_scene(text=metadata["scene_text"], overrides=overrides or {}).data[
                    "camera"
                ]
            except ValueError:
                settings = None
        return sim, settings, {}
    from .runs import load_scene

    scene = load_scene(source, overrides=overrides)
    sim, _ = scene.build()
    if scene.data["simulation"]["settle"] > 0.0:
        # the scene's starting state is its settled cloth, as in `yore run`
        sim.settle(scene.data["simulation"]["settle"])
    strokes = scene.data.get("strokes") or []
    first = {}
    if strokes:
        for name in ("expansion", "mass_scale", "width", "growth", "refine"):
            if strokes[0].get(name) is not None:
                first[name] = strokes[0][name]
    return sim, scene.data.get("camera"), first


def _run_view(arguments, overrides) -> None:
    """``yore view``: a scene or state in the viewer's window, or scripted headless."""
    from .camera import camera_from_settings
    from .viz.viewer import Viewer, densify, parse_pixels

    if not arguments.headless and (
        arguments.stroke_px or arguments.at is not None or arguments.until is not None
    ):
        raise ValueError("--stroke-px, --at and --until script a headless view: add --headless")
    if arguments.headless and arguments.screenshot is None:
        raise ValueError("a headless view shows nothing: give --screenshot PICTURE.png")
    if arguments.screenshot is not None and arguments.screenshot.suffix.lower() != ".png":
        raise ValueError(f"--screenshot writes PNG files; got {str(arguments.screenshot)!r}")
    strokes = [parse_pixels(text) for text in arguments.stroke_px]
    for pixels in strokes:
        densify(pixels)  # its sample limit, before the scene is loaded and run
    for name in ("at", "until"):
        value = getattr(arguments, name)
        if value is not None and not (math.isfinite(value) and 0.0 <= value <= 1e6):
            raise ValueError(f"--{name} must be a time in [0, 1e6] s, got {value}")
    sim, settings, first = _view_source(arguments.source, overrides)
    at = sim.time if arguments.at is None else arguments.at
    until = at if arguments.until is None else arguments.until
    if at < sim.time - 1e-12:
        raise ValueError(f"--at {at} s is before the simulation's time {sim.time:.6g} s")
    if until < at:
        raise ValueError(f"--until {until} s is before --at {at} s")
    options = dict(first)
    for name, value in (
        ("expansion", arguments.expansion),
        ("width", arguments.stroke_width),
        ("growth", arguments.growth),
        ("refine", arguments.refine),
        ("smooth", arguments.smooth),
    ):
        if value is not None:
            options[name] = value
    camera = camera_from_settings(
        settings,
        sim.cloth.positions,
        arguments.width,
        arguments.height,
        arguments.eye,
        arguments.target,
        arguments.up,
        arguments.fov,
    )
    viewer = Viewer(sim, camera, headless=arguments.headless, stroke_options=options)
    if not arguments.headless:
        if not getattr(arguments, "quiet", False):
            viewer.log = lambda text: print(f"yore view: {text}", flush=True)
        viewer.show()
        return
    quiet = getattr(arguments, "quiet", False)

    def run_to(target):
        if target > viewer.sim.time:
            # Simulation.advance shows its own progress bar on a terminal for long runs
            viewer.advance(target - viewer.sim.time, progress=False if quiet else None)

    run_to(at)
    for k, pixels in enumerate(strokes):
        reports = viewer.stroke_pixels(pixels)
        if not quiet:
            print(
                f"stroke {k + 1} at t = {viewer.sim.time:.3f} s: "
                f"{sum(r.faces_split for r in reports)} faces split, "
                f"{sum(r.vertices_added for r in reports)} vertices added"
                + (f" ({len(reports)} pieces)" if len(reports) > 1 else "")
            )
    run_to(until)
    path = viewer.save_picture(arguments.screenshot, panel=arguments.panel)
    if not quiet:
        print(f"picture:      {Path(path).resolve()}")


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
    finally:
        warnings.formatwarning = shown
        end_command()  # the `yore` command ignores a Ctrl-C in its shutdown (see yore.runtime)


def _one_line_warning(message, category, filename, lineno, line=None):
    return f"yore: warning: {' '.join(str(message).split())}\n"


def _main(argv) -> int:
    from .runtime import end_command_start

    end_command_start()  # Ctrl-C is main's to handle from here (see yore.runtime)
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:2] == ["sweep", "plot"]:
        argv = ["sweep-plot", *argv[2:]]
    try:
        parser = _parser()
        arguments, unknown = parser.parse_known_args(argv)
        if unknown:  # named by the command's parser, whose --help lists its options
            commands = next(a for a in parser._actions if a.dest == "command").choices
            command = commands.get(getattr(arguments, "command", None), parser)
            command.error(f"unrecognized arguments: {' '.join(unknown)}")
        from .runs import RunError
    except KeyboardInterrupt:  # it landed while the parser was built: nothing ran yet
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
        state = getattr(interruption, "state_path", None)
        print(
            f"yore: {interruption}; `yore run --resume {state}` continues"
            if state
            else f"yore: {interruption}"
            if str(interruption)
            else "yore: interrupted",
            file=sys.stderr,
        )
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
