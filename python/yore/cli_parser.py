"""The ``yore`` command's argument parser (`yore.cli` runs the commands): every command's
arguments, their help, and the exit codes."""

from __future__ import annotations

import argparse
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage errors as one line and exit code 2 (as argparse does)."""

    def error(self, message):
        # the command as typed ("yore sweep plot", "yore run"), whose --help says more
        self.exit(EXIT_BAD_INPUT, f"yore: error: {message} (see `{self.prog} --help`)\n")


def build_parser():
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


def scene_overrides(arguments):
    from .runs import parse_override

    return dict(parse_override(text) for text in arguments.overrides)
