"""Scene files and runs: the layer above the simulation that describes a whole run in a TOML
file, checks it, builds it and runs it (what ``yore run``, ``yore check`` and ``yore demo`` do).

- `yore.runs.schema` — the scene file's tables and keys (`SCHEMA`), `SceneError` and the
  limits (`MAX_SCENE_FILE_BYTES`, `MAX_INTEGER`), with `yore.runs.scene_rules` (the keys'
  validators) and `yore.runs.scene_tables` (the checked tables' classes);
- `yore.runs.loading` — `Scene` and `load_scene`: reading the text, ``--set`` overrides
  (`parse_override`) and every check (`yore.runs.scene_checks`), with the key's line in the
  file;
- `yore.runs.building` — the Simulation a `Scene` describes (`Scene.build`), its camera
  (`scene_camera`) and its strokes (`apply_scene_stroke`);
- `yore.runs.runner` — running a scene into a folder (`run_scene`, `resume_run`, which continues
  a state exactly, `check_scene`), with its parts: `yore.runs.folder` (the run's files, claiming
  a folder), `yore.runs.stepping` (one part of a run: strokes at their times, frames, state
  files on the way, the summary) and `yore.runs.output` (what a frame, a state, a stroke and
  the summary record);
- `yore.runs.demo` — ``yore demo``: the paper's first experiment three ways.

The schema imports only its rules; building uses the schema (a Scene is only
read, not imported), loading uses both (`Scene.build` and `Scene.check_strokes` call building),
the runner (with its parts) all three and the demo the runner. The mesh, the core, the simulation and the
pictures (`yore.render`, `yore.render_run`) live in the package above.
"""

from __future__ import annotations

from .schema import SceneError
from .building import apply_scene_stroke, scene_camera
from .loading import Scene, load_scene, parse_override
from .runner import RunError, RunInterrupted, STATE_NAME, SUMMARY_NAME, resume_run, run_scene
from .demo import demo_scene_text, paper_scene_text, run_demo

__all__ = [
    "SceneError",
    "Scene",
    "load_scene",
    "parse_override",
    "apply_scene_stroke",
    "scene_camera",
    "run_scene",
    "resume_run",
    "RunError",
    "RunInterrupted",
    "SUMMARY_NAME",
    "STATE_NAME",
    "run_demo",
    "demo_scene_text",
    "paper_scene_text",
]
