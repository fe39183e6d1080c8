"""The vision library's own benchmark: ``python -m pipeline.bench`` prints JSON.

- no mode: the default pad, 1-6 m, today's degradation mix (figures comparable
  with every earlier run);
- ``--design NAME|all``: per pad design (`pipeline.render.DESIGNS`), with a summary;
- ``--sweep altitude|snr|tilt|yaw``: detection, pose error and time per point for
  Visland, ArUco and AprilTag 3 on the same poses, and range90 (`pipeline.bench.sweep`);
- ``--report DIR``: the dissertation's experiments reproduced (`pipeline.bench.report`);
- ``--vector``: the pose on frames drawn another way, the pad as vector polygons
  (`pipeline.bench.vector`);
- ``--photos DIR [--augment K]``: real photos of H pads, as they are and seen K more
  ways through real-world degradations (`pipeline.bench.photos`).

One core (OpenCV and the BLAS on one thread, `pipeline.cores`; one torch thread); times
are wall-clock per frame.
"""

from pipeline.bench.accuracy import run, run_designs

__all__ = ["run", "run_designs"]
