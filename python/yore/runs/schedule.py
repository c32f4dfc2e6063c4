"""A run's event schedule: the steps at which its strokes are drawn and its frames written.

Time is counted in steps: the run has round(duration / dt) steps, a stroke at time t is drawn
before step round(t / dt), and frames are written every ``frame_interval`` steps and at the
end; so a run split and resumed takes exactly the steps of a straight run."""

from __future__ import annotations

from .loading import step_of

__all__ = ["EventSchedule", "frame_due"]


def frame_due(step, every, duration_step):
    """Whether a frame is written at ``step``: every ``every`` steps and at the scene's end. A
    part stopped by ``until`` between frames writes none there (its state file holds the
    cloth), so a run split and resumed writes the frames a straight run writes."""
    return step % every == 0 or step == duration_step


class EventSchedule:
    """The strokes and frames of a scene run at step ``dt`` up to ``last_step``.

    strokes: (step, stroke index) in the order they are drawn (by step, then index). every:
    steps between frames. duration_step: the scene's last step (a frame is written there).
    """

    def __init__(self, scene, dt, last_step):
        data = scene.data
        self.every = scene.frame_interval(dt)
        self.duration_step = step_of(data.simulation.duration, dt)
        self.last_step = last_step
        self.strokes = sorted((step_of(s.time, dt), k) for k, s in enumerate(data.strokes))

    def frame_due(self, step) -> bool:
        return frame_due(step, self.every, self.duration_step)

    def stroke_due(self, step, next_stroke):
        """The index of the next stroke to draw if it is due at ``step`` (None otherwise)."""
        if next_stroke < len(self.strokes) and self.strokes[next_stroke][0] <= step:
            return self.strokes[next_stroke][1]
        return None

    def next_event(self, step, next_stroke, most):
        """The step to advance to from ``step``: the next stroke's, the next frame's, the last
        step, or ``step + most``, whichever comes first."""
        next_stroke_step = (
            self.strokes[next_stroke][0] if next_stroke < len(self.strokes) else self.last_step
        )
        next_frame = (step // self.every + 1) * self.every
        return min(next_stroke_step, next_frame, self.last_step, step + most)
