"""The digital twin: how big a recorded drive is, how fast it records, how fast it follows.

A recorded twin goes into the driving chapter (viewer shared) and into lab 5's feedback
(viewer inlined once); a live twin must keep up with 20 frames a second in JupyterLab.
Measured on a 26 s drive (the scripted square's length) without ROS in the loop.
"""

from __future__ import annotations

import time

from benchmarks import Figure, sized
from rosbook.sim.physics import DiffDriveSim
from rosbook.viz import scene as viz
from rosbook.viz import twin

SECONDS = sized(26.0, 2.0)
KB = 1e3


def _drive() -> DiffDriveSim:
    sim = DiffDriveSim()
    sim.command(0.25, 0.3)
    sim.run(SECONDS)
    return sim


def run() -> list[Figure]:
    sim = _drive()
    figures = []
    for fps in (10, 15, 20):
        started = time.perf_counter()
        scene = twin.record(sim, fps=fps)
        took = time.perf_counter() - started
        figures.append(
            Figure(f"recorded twin, {SECONDS:g} s at {fps} fps", scene.nbytes() / KB, "kB")
        )
        figures.append(Figure(f"time to record it ({fps} fps)", took * 1000, "ms"))
    scene = twin.record(sim, fps=twin.DEFAULT_FPS)
    figures.append(
        Figure("same twin inlined for feedback (viewer copy)", len(scene.inline_html()) / KB, "kB")
    )
    vis = viz.live_visualizer()
    try:
        live = twin.Twin(vis=vis)
        follow = DiffDriveSim()
        follow.command(0.25, 0.3)
        started = time.perf_counter()
        live.follow(follow, SECONDS, fps=20, realtime=False)
        took = time.perf_counter() - started
    finally:
        viz.close_live(vis)
    figures.append(
        Figure("live twin updates per wall second (target >= 20)", SECONDS * 20 / took, "1/s")
    )
    return figures
