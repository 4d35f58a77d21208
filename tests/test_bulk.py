"""A study's variants read in bulk (derive.scene.bulk, derive.runtime.study) against the
per-scene validator, one variant at a time: over thousands of random override sets,
bad ones among them, the same verdicts, the same refusals (messages naming the variant
and the field), the same model and the same options, parameters and start, bit for bit;
and every rule that reads a field a study varies in bulk has a form over columns."""
from __future__ import annotations

import copy

import numpy as np
import pytest

import derive
from derive.bench.sim import ellipsoid_doc
from derive.runtime import study
from derive.scene import SceneError, builtin_doc, bulk, rules
from derive.scene.rules import Draft
from derive.scene.schema import SCENE


def _scenes() -> dict:
    """Base scenes for every model a bulk study can reach (and some it hands on)."""
    out = {"sphere": builtin_doc(), "ellipsoid": ellipsoid_doc()}
    d = builtin_doc()
    d["run"]["outputs"] = ["impacts"]
    out["vertical"] = d
    d = builtin_doc()
    del d["plane"]
    d["run"]["outputs"] = ["omega"]
    out["attitude"] = d
    d = builtin_doc()
    d["plane"]["friction"] = 0.4
    out["rough"] = d
    d = builtin_doc()
    d["run"].update(method="rk4", duration=2.0)
    out["rk4"] = d
    d = builtin_doc()                      # omega = 0 and a vertical law: translational
    d["initial"]["omega"] = [0.0, 0.0, 0.0]
    d["point"]["law"] = ["0.0", "0.0", "0.1*sin(2*t)"]
    out["translational"] = d
    d = builtin_doc()                      # free flight, J_x = J_y, P on the axis
    del d["plane"]
    d["body"]["inertia"] = [0.1, 0.1, 0.14]
    d["point"]["law"] = ["0.0", "0.0", "0.1*sin(2*t)"]
    out["axisymmetric"] = d
    d = builtin_doc()
    d["body"] = {"mass": 1.0, "inertia": [0.1, 0.12, 0.14], "shape": "none"}
    del d["plane"]
    out["shapeless"] = d
    return out


NAMES = ["body.mass", "point.mass", "body.inertia", "body.inertia[0]", "body.inertia[2]",
         "plane.restitution", "run.g", "run.rtol", "run.atol", "initial.com",
         "initial.com[2]", "initial.com_velocity", "initial.com_velocity[1]",
         "initial.omega", "initial.omega[0]", "initial.omega[2]"]
OTHERS = ["run.duration", "initial.quaternion", "body.center"]     # not read in bulk
# values of a type check_number converts, which the bulk read leaves to the per-scene
# path (where it may accept them)
LENIENT = (np.float32, np.int64)


def _bad(rng):
    return [-1.0, 0.0, float("nan"), float("inf"), 1e12, "1.0", True, None, 2 ** 60, [1.0],
            np.float32(0.5), np.int64(2)][int(rng.integers(0, 12))]


def _number(name: str, rng):
    if rng.random() < 0.08:
        return _bad(rng)
    if rng.random() < 0.05:
        return int(rng.integers(1, 3))
    if name.endswith("mass"):
        return float(rng.uniform(0.05, 3.0))
    if name == "plane.restitution":
        return float(rng.uniform(0.0, 1.0)) if rng.random() < 0.95 else 1.0 + 1e-9
    if name == "run.g":
        return float(rng.uniform(0.0, 20.0))
    if name == "run.rtol":
        return float(10 ** rng.uniform(-12, -6))
    if name == "run.atol":
        return float(10 ** rng.uniform(-14, -8))
    if name.startswith("body.inertia"):
        return float(rng.choice([rng.uniform(0.05, 0.3), 1e-11, 0.6]))
    if name.startswith("initial.com["):
        return float(rng.uniform(0.2, 2.5))         # below the plane now and then
    if name.startswith("initial.com_velocity"):
        return float(rng.uniform(-2, 2))
    return float(rng.choice([0.0, rng.uniform(-3, 3)]))        # omega: zero now and then


def _vector(name: str, rng):
    if rng.random() < 0.06:
        return _bad(rng)
    if rng.random() < 0.03:
        return [1.0, 2.0]                                       # of the wrong length
    if name == "body.inertia":
        J = rng.uniform(0.05, 0.3, 3)
        if rng.random() < 0.1:
            J[int(rng.integers(0, 3))] = float(J.sum())          # beyond the other two
        return [float(x) for x in J]
    if name == "initial.com":
        return [float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)),
                float(rng.uniform(0.3, 2.5))]
    if name == "initial.omega":
        w = rng.uniform(-3, 3, 3)
        if rng.random() < 0.3:
            w[:2 + int(rng.integers(0, 2))] = 0.0                # along z, or zero
        return [float(x) for x in w]
    if name == "body.center":
        return [float(x) for x in rng.uniform(-0.1, 0.1, 3)]
    if name == "initial.quaternion":
        return [float(x) for x in rng.normal(size=4)]
    return [float(x) for x in rng.uniform(-2, 2, 3)]


def _value(name: str, rng):
    if name == "run.duration":
        return float(rng.uniform(0.5, 3.0))
    whole = name in ("body.inertia", "initial.com", "initial.com_velocity", "initial.omega",
                     "body.center", "initial.quaternion")
    return _vector(name, rng) if whole else _number(name, rng)


def _lenient(changes: dict) -> bool:
    def of(x):
        return isinstance(x, LENIENT) or (isinstance(x, list) and any(map(of, x)))
    return any(of(x) for x in changes.values())


def test_bulk_and_per_scene_validation_agree_on_random_studies():
    """Thousands of random variants in groups that share their overridden fields, on
    scenes of every model: each group read in bulk (where it can be) and each variant
    through the per-scene path give the same verdict; a variant the bulk read passes has
    the model, start, options and parameters of its own prepare, bit for bit."""
    rng = np.random.default_rng(31)
    counts = {"bulk_ok": 0, "bulk_refused": 0, "lenient": 0, "singles": 0, "groups": 0}
    kinds = set()
    for label, doc in _scenes().items():
        base_v, base_given = SCENE.read(doc)
        for _ in range(50):
            names = list(rng.choice(NAMES, size=int(rng.integers(1, 4)), replace=False))
            if rng.random() < 0.1:
                names.append(str(rng.choice(OTHERS)))
            n = int(rng.integers(2, 16))
            variants = [{name: _value(name, rng) for name in names} for _ in range(n)]
            items = list(enumerate(variants))
            cols = bulk.read(base_v, base_given, tuple(names), variants, "variant", None)
            plan = study.plan(doc, None, items)
            in_parts = {int(i): (p, k) for p in plan.parts for k, i in enumerate(p.index)}
            assert len(in_parts) + len(plan.singles) == n, label
            for i, changes in items:
                try:
                    alone = study.prepare_variant(doc, None, base_v, base_given, i, changes)
                except SceneError:
                    alone = None
                if cols is not None and not _lenient(changes):
                    assert bool(cols.ok[i]) == (alone is not None), (label, changes)
                if i in in_parts:
                    part, k = in_parts[i]
                    assert alone is not None and part.kind == alone.kind, (label, changes)
                    assert np.array_equal(part.q0[k], alone.start.q0), (label, changes)
                    assert np.array_equal(part.opt[k], alone.options), (label, changes)
                    assert np.array_equal(part.prm[k], alone.parameters), (label, changes)
                    assert part.law is alone.scene.law
                    kinds.add(part.kind)
                    counts["bulk_ok"] += 1
                elif cols is not None:
                    counts["lenient" if _lenient(changes) and alone is not None else
                           "bulk_refused" if alone is None else "singles"] += 1
                else:
                    counts["singles"] += 1
            counts["groups"] += cols is not None
    assert kinds == {"general", "vertical", "attitude", "rough"}, kinds
    assert counts["bulk_ok"] > 1500 and counts["bulk_refused"] > 800, counts
    assert counts["lenient"] > 5 and counts["singles"] > 300, counts


def _refusal(doc: dict, changes: dict) -> str | None:
    """parse_scene's message for the scene with these overrides (None: accepted)."""
    d = copy.deepcopy(doc)
    for name, value in changes.items():
        derive.scene.overrides.apply_to_doc(d, name, value)
    try:
        derive.scene.parse_scene(d)
    except SceneError as exc:
        return str(exc)
    return None


def test_a_study_refuses_as_one_scene_does():
    """The refusals of a study read in bulk are those of one scene: the variant named,
    then the field and the rule as parse_scene words them for that variant's scene (or,
    where several overrides are bad, for one of them alone: a study reads a variant's
    overrides in the order given, a file in the schema's)."""
    rng = np.random.default_rng(5)
    doc = builtin_doc()
    doc["run"]["duration"] = 0.3
    names = ["body.mass", "initial.com[2]", "body.inertia", "plane.restitution"]
    variants = [{name: _value(name, rng) for name in names} for _ in range(150)]
    out = derive.simulate_many(doc, variants, workers=1, strict=False)
    refused = 0
    for k, changes in enumerate(variants):
        whole = _refusal(doc, changes)
        if whole is None:
            assert out.rows[k].get("status") == "done", (changes, out.rows[k])
            continue
        refused += 1
        each = {_refusal(doc, {name: value}) for name, value in changes.items()}
        assert out.rows[k]["error"] in {f"variant {k + 1}: {m}" for m in each | {whole}
                                        if m is not None}, (changes, out.rows[k], whole)
    assert 20 < refused < 140 and out.tasks >= 2


def test_a_bulk_study_equals_its_variants_run_alone():
    """The summary columns of variants read and run in bulk equal those of each variant's
    own Result (keep = "result": one run at a time), on three models."""
    rng = np.random.default_rng(9)
    for label in ("sphere", "vertical", "rough"):
        doc = _scenes()[label]
        doc["run"]["duration"] = 1.5
        variants = [{"body.mass": float(rng.uniform(0.8, 1.2)),
                     "plane.restitution": float(rng.uniform(0.5, 0.9)),
                     "initial.omega": [float(x) for x in rng.uniform(-1, 1, 3)]}
                    for _ in range(12)]
        many = derive.simulate_many(doc, variants, workers=2, chunk=4)
        alone = derive.simulate_many(doc, variants, workers=1, keep="result")
        assert many.executor == "threads" and many.tasks == 3
        for a, b in zip(many.rows, alone.rows):
            assert a["model"] == label.replace("sphere", "general")
            assert all(a[c] == b[c] or (a[c] != a[c] and b[c] != b[c])
                       for c in a if c != "run_ms"), (a, b)


class _Reads(dict):
    """Field values that record which fields are read."""

    def __init__(self, values: dict, log: set):
        super().__init__(values)
        self.log = log

    def __getitem__(self, key):
        self.log.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.log.add(key)
        return super().get(key, default)


class _Traced(Draft):
    """A draft that records the draft's attributes read."""

    def __getattribute__(self, name):
        log = object.__getattribute__(self, "__dict__").get("_attrs")
        if log is not None and not name.startswith("_") and name != "v":
            log.add(name)
        return object.__getattribute__(self, name)


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    return a == b


def _derived(v: dict, given: set) -> dict:
    """The draft's attributes after every rule."""
    d = Draft(dict(v), set(given))
    rules.check(rules.STATIC_RULES + rules.STATE_RULES, d)
    return {k: x for k, x in d.__dict__.items() if k not in ("v", "given")}


def _nudged(where: str, x):
    return tuple(c * 1.05 + 0.01 for c in x) if isinstance(x, tuple) else x * 0.95


def test_every_rule_that_reads_a_bulk_field_has_a_bulk_form():
    """On scenes of every model: the fields each rule reads (traced) and the draft's
    attributes it reads that an earlier rule derived from a bulk field (those that
    change when that field is nudged); a rule reading a field of bulk.BULK either way
    must have a form over columns (else a study varying that field would skip it)."""
    offenders, readers = set(), set()
    for doc in _scenes().values():
        v, given = SCENE.read(doc)
        before = _derived(v, given)
        tainted = {}
        for where in bulk.BULK:
            if isinstance(v.get(where), (float, tuple)):
                after = _derived({**v, where: _nudged(where, v[where])}, given)
                for attr, x in before.items():
                    if not _same(x, after[attr]):
                        tainted.setdefault(attr, set()).add(where)
        fields, attrs = set(), set()
        d = _Traced(_Reads(v, fields), set(given))
        for rule in rules.STATIC_RULES + rules.STATE_RULES:
            fields.clear()
            d._attrs = attrs
            attrs.clear()
            rule.check(d)
            d.__dict__.pop("_attrs")
            reads = (fields | set().union(*(tainted.get(a, set()) for a in attrs
                                              if a != "extra"))) & bulk.BULK
            if reads:
                readers.add(rule.check.__name__)
                if rule.bulk is None:
                    offenders.add((rule.check.__name__, tuple(sorted(reads))))
    assert not offenders, offenders
    assert {"_inertia", "_reach", "_rk4_step", "_above_plane"} <= readers, readers


@pytest.mark.parametrize("changes", [
    {"body.mass": [1.0, 2.0]},                   # a field outside BULK
    {"run.duration": [1.0, 2.0]},
])
def test_what_bulk_does_not_read_goes_one_by_one(changes):
    doc = builtin_doc()
    base_v, base_given = SCENE.read(doc)
    name, values = next(iter(changes.items()))
    variants = [{name: x} for x in values]
    if name == "run.duration":
        assert bulk.read(base_v, base_given, (name,), variants) is None
    else:
        cols = bulk.read(base_v, base_given, (name,), variants)
        assert cols is not None and cols.ok.all()
        shapeless = _scenes()["shapeless"]
        v2, g2 = SCENE.read(shapeless)
        assert bulk.read(v2, g2, (name,), variants) is None    # M sizes max_distance
    assert bulk.read(base_v, base_given, (name,), variants[:1]) is None
