"""The viewer's model without a window: picking by the core's rays, strokes with the panel's
options and smoothing, undo and reset bit for bit, and its refusals. (It imports no polyscope:
a subprocess checks, since this process may have loaded it for other tests.)"""

import subprocess
import sys

import numpy as np
import pytest

import yore
from yore.viz.viewer_model import ViewerModel


def _model(**options):
    sim = yore.scenes.hanging_cloth(resolution=9)
    sim.advance(0.05)
    camera = yore.Camera(eye=(0.5, -0.4, 2.2), target=(0.5, -0.45, 0.0), width=320, height=240)
    return ViewerModel(sim, camera, stroke_options=options)


def test_a_drag_over_the_cloth_is_a_stroke_that_undo_takes_back_bit_for_bit():
    model = _model(smooth=3)
    before = model.sim.state()
    X = model.sim.cloth.positions
    pixels = model.camera.project(X[[9 * 4 + 1, 9 * 4 + 7]])
    reports = model.stroke_pixels(pixels)
    assert len(reports) == 1 and reports[0].faces_split > 0
    assert "smoothing" in reports[0].extra  # the panel's smoothing ran as the last stage
    assert model.sim.cloth.vertex_count > len(X)
    assert model.message.startswith("stroke at t = ")
    assert model.undo()
    after = model.sim.state()
    assert np.array_equal(after["cloth"]["positions"], before["cloth"]["positions"])
    assert np.array_equal(after["cloth"]["spring_rest"], before["cloth"]["spring_rest"])
    assert not model.undo() and model.message == "nothing to undo"


def test_picking_misses_off_the_cloth_and_a_stroke_there_is_refused():
    model = _model()
    hits, faces, weights = model.pick_surface([[1.0, 1.0], [319.0, 239.0]])
    assert len(hits) == len(faces) == len(weights) == 0
    with pytest.raises(yore.StrokeMissed):
        model.stroke_pixels([[1.0, 1.0], [5.0, 1.0]])
    assert model.sim.cloth.vertex_count == 81  # nothing changed
    with pytest.raises(ValueError, match="unknown stroke option 'colour'"):
        _model(colour=1)
    with pytest.raises(ValueError, match=r"smooth \(iterations\) must be an integer in"):
        _model(smooth=10**6)


def test_the_model_needs_no_polyscope():
    code = (
        "import sys, yore; from yore.viz.viewer_model import ViewerModel; "
        "m = ViewerModel(yore.scenes.hanging_cloth(resolution=5)); m.step_frame(); "
        "print('polyscope' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
