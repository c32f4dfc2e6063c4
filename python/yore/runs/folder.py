"""A run's folder: the files a run writes there, and claiming a folder for a run so that
frames of two runs never mix (`yore.runs.runner` runs into it)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from ..state import load_metadata
from .record import BEFORE_NAME, FRAMES_DIR

SUMMARY_NAME = "summary.json"
STATE_NAME = "state.npz"


#: Files a run writes into its folder (besides frames/).
RUN_FILES = (
    SUMMARY_NAME,
    STATE_NAME,
    BEFORE_NAME,
    "before_after.png",
    "last.png",
    "animation.gif",
    "animation.mp4",
)


def run_files(out) -> list:
    """The files of a yore run in folder ``out`` (its summary, state, frames, pictures), as
    paths; empty when the folder holds no run."""
    out = Path(os.fspath(out))
    found = [out / name for name in RUN_FILES if (out / name).is_file()]
    frames = out / FRAMES_DIR
    if frames.is_dir():
        found += sorted(
            p
            for p in frames.iterdir()
            if p.is_file()
            and (
                p.name.startswith("frame_") or p.name == "frame.pvd" or p.name.startswith(".frame_")
            )
        )
    return found


def claim_folder(out, record, overwrite=False) -> None:
    """Makes ``out`` ready for the run ``record`` describes (a new run, or a resumed one
    writing elsewhere). A folder holding no run is used as it is. A folder holding a run is
    cleared of that run's files (nothing else) when ``overwrite`` is true, or when it holds a
    finished run of the very same scene (scene text and overrides): running it again repeats
    it. Anything else raises ValueError saying how to continue or replace it, so frames of two
    runs never mix."""
    out = Path(os.fspath(out))
    if out.exists() and not out.is_dir():
        raise ValueError(f"output folder {out} is a file")
    found = run_files(out)
    if not found:
        return
    if not overwrite:
        previous = _previous_run(out)
        same = (
            previous is not None
            and previous.get("status") == "finished"
            and previous.get("scene_text") == record.scene_text
            and previous.get("overrides") == record.overrides
        )
        if not same:
            what = (
                "an unfinished run of the same scene"
                if previous is not None
                and previous.get("scene_text") == record.scene_text
                and previous.get("overrides") == record.overrides
                else "another run"
            )
            hint = (
                f"continue it with `yore run --resume {out / STATE_NAME}`, "
                if (out / STATE_NAME).is_file()
                else ""
            )
            raise ValueError(
                f"output folder {out} already holds {what} ({len(found)} files, "
                f"e.g. {found[0].name}); {hint}replace it with --overwrite, or "
                "choose another folder with -o"
            )
    for path in found:
        path.unlink()
    frames = out / FRAMES_DIR
    if frames.is_dir() and not any(frames.iterdir()):
        frames.rmdir()


def _previous_run(out):
    """{"status", "scene_text", "overrides"} of the run in ``out``, or None if unreadable."""
    try:
        metadata = load_metadata(out / STATE_NAME)
        # no summary: the run stopped without one (killed after a periodic state save)
        summary = (
            json.loads((out / SUMMARY_NAME).read_text(encoding="utf-8"))
            if (out / SUMMARY_NAME).is_file()
            else {"status": "unfinished"}
        )
        return {
            "status": summary.get("status"),
            "scene_text": metadata.get("scene_text"),
            "overrides": metadata.get("overrides"),
        }
    except (OSError, ValueError, AttributeError):
        return None
