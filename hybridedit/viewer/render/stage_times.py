"""Where the window's frames go: per-stage time sums for the status bar and benchmarks/window_fps.py."""

from __future__ import annotations

STAGES = ("engine", "points", "normals", "vtk update", "render", "compose")
"""engine: the engine's drag; points: the moving rows into the full-mesh float32 buffer, and their
bounds; normals: the moving region's normals (these three on the frame thread during drags, beside
the render); vtk update: copying the changed rows into the buffers VTK draws; render: VTK's render
and buffer swap; compose: Qt putting the rendered frame on screen afterwards (none with the native
view, where VTK swaps the window's buffers itself)."""


class FrameSplit:
    """Running sums of seconds per stage since the last :meth:`reset`."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.seconds = dict.fromkeys(STAGES, 0.0)
        self.counts = dict.fromkeys(STAGES, 0)

    def add(self, stage: str, seconds: float) -> None:
        self.seconds[stage] += float(seconds)
        self.counts[stage] += 1

    def mean_ms(self, stage: str) -> float:
        """Mean milliseconds per occurrence of ``stage`` (0 if none)."""
        n = self.counts[stage]
        return 1e3 * self.seconds[stage] / n if n else 0.0
