"""Closing the loop: controllers that act through the point's motion.

* :mod:`~derive.control.plant`: the plant a controller acts on (the scene with its
  ``[disturbance]``) and the loop's noise and pushes;
* :mod:`~derive.control.hop`: per-hop feedback on the impact-to-impact (Poincare) map of
  a periodic hop, and the mirror law it is compared with;
* :mod:`~derive.control.replan`: the plan re-solved in flight, as generated C
  (``templates/control/``): the pipeline of ``derive control``, over the problem
  (:mod:`~derive.control.problem`), the law (:mod:`~derive.control.spline`), the C's
  rendering (:mod:`~derive.control.render`, :mod:`~derive.control.compiled`) and the
  solvers in Python (:mod:`~derive.control.solvers`: its Python route, IPOPT
  in-process);
* :mod:`~derive.control.qp`: the re-planner's dense QP solver (Goldfarb-Idnani), the
  NumPy statement of ``ctl_qp.h``;
* :mod:`~derive.control.core`: ``derive.control`` (the dispatch on ``[control].mode``,
  the plant of a plan, the measurements, the outputs); :mod:`~derive.control.cli`:
  ``derive control TASK.toml``; :mod:`~derive.control.plots`: its pictures.

The runtime side of the loop (samples, events, the law a controller sets, noise, pushes)
is :mod:`derive.runtime.loop` and ``crt_control.h``.
"""
