"""Closing the loop: controllers that act through the point's motion.

* :mod:`~derive.control.plant`: the plant a controller acts on (the scene with its
  ``[disturbance]``) and the loop's noise and pushes;
* :mod:`~derive.control.hop`: per-hop feedback on the impact-to-impact (Poincare) map of
  a periodic hop, and the mirror law it is compared with;
* :mod:`~derive.control.replan`: the plan re-solved in flight, as generated C;
* :mod:`~derive.control.core`: ``derive control TASK.toml`` and ``derive.control``.

The runtime side of the loop (samples, events, the law a controller sets, noise, pushes)
is :mod:`derive.runtime.loop` and ``crt_control.h``.
"""
