"""Scenes: the TOML files (or dicts) through which people use the toolkit, read and
validated below the runtime.

* :mod:`~derive.scene.schema`: every field of a scene and of a task's ``[plan]``, in one
  table, and the checks of single values;
* :mod:`~derive.scene.rules`: the rules across fields, each its text and its check;
* :mod:`~derive.scene.parse`: from a document to a :class:`Scene`;
* :mod:`~derive.scene.cache`: scenes seen before re-validate only their initial state;
* :mod:`~derive.scene.overrides`: ``body.mass=1.3`` and ``initial.com[2]``, one parser;
* :mod:`~derive.scene.bulk`: a study's overrides of many variants checked at once, by the
  same fields and rules over NumPy columns;
* :mod:`~derive.scene.law` and :mod:`~derive.scene.table`: the point law as formulas (a
  whitelist parser, interval proofs) or as samples (a cubic spline);
* :mod:`~derive.scene.toml`: the one TOML writer;
* :mod:`~derive.scene.docs`: the README's tables, ``derive scene new``, the built-in
  scene.
"""
from __future__ import annotations

from . import overrides
from .docs import DEFAULT_SCENE, builtin_doc, plan_table, schema_table, template
from .errors import SceneError
from .parse import build_body, build_scene, load, load_scene, parse, parse_scene
from .scene import Scene, Stability

__all__ = ["DEFAULT_SCENE", "Scene", "SceneError", "Stability", "build_body", "build_scene",
           "builtin_doc", "load", "load_scene", "overrides", "parse", "parse_scene",
           "plan_table", "schema_table", "template"]
