"""Experiment, bounds, scene and report documents: the C++ validator (_core.parse_document, the one
path every document takes) against Debian's python3-jsonschema (a test dependency only) on a corpus
of good and bad documents (tests/data/documents).

Bad files each break one rule; bad/expected.json maps each to the JSON pointer the C++ error must
name. Files named semantic_* break a rule beyond the schema (jsonschema accepts them), syntax_* are
not JSON at all; every other bad file must be rejected by jsonschema too.
"""
import copy
import json
import re
from pathlib import Path

import jsonschema
import pytest

from glintlab import _core
from glintlab.validation import documents

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "tests" / "data" / "documents"
SCHEMAS = {kind: json.loads((ROOT / "python" / "glintlab" / "data" / "schema" / f"{kind}.schema.json").read_text())
           for kind in ("experiment", "bounds", "scene", "report")}
EXPECTED = json.loads((DOCS / "bad" / "expected.json").read_text())
GOOD = sorted(p.name for p in (DOCS / "good").glob("*.json"))
BAD = sorted(p.name for p in (DOCS / "bad").glob("*.json") if p.name != "expected.json")


def validator(kind):
    # bounds.schema.json refers to "experiment.schema.json#/definitions/...", relative to its $id.
    # All four schemas are draft-07 (scene and report use allOf with if/then, const and the exclusive limits).
    store = {s["$id"]: s for s in SCHEMAS.values()}
    resolver = jsonschema.RefResolver.from_schema(SCHEMAS[kind], store=store)
    return jsonschema.Draft7Validator(SCHEMAS[kind], resolver=resolver)


def kind_of(name):
    return re.sub(r"^(semantic|syntax)_", "", name).split("_")[0]


def cpp_error(kind, text, source):
    with pytest.raises(_core.InputError) as info:
        _core.parse_document(kind, text, source)
    message = str(info.value)
    match = re.match(re.escape(source) + r": at (/[^:]*?): expected (.*), got (.*)$", message, re.S)
    assert match, message
    return match.group(1), match.group(2), match.group(3)


def test_schemas_are_draft7_and_embedded():
    for kind, schema in SCHEMAS.items():
        jsonschema.Draft7Validator.check_schema(schema)
        assert json.loads(_core.schema_text(kind)) == schema
    assert issubclass(_core.InputError, ValueError)


def test_corpus_is_complete():
    assert len(GOOD) >= 10 and len(BAD) >= 30
    assert sorted(EXPECTED) == BAD
    assert {kind_of(n) for n in GOOD + BAD} == set(SCHEMAS)


@pytest.mark.parametrize("name", GOOD)
def test_good_document(name):
    kind = kind_of(name)
    text = (DOCS / "good" / name).read_text(encoding="utf-8")
    raw = json.loads(text)
    validator(kind).validate(raw)
    doc = json.loads(_core.parse_document(kind, text, name))
    # Normalizing only adds defaults (and writes integral numbers as integers): the result is still
    # valid, every given value is kept, and normalizing again changes nothing.
    validator(kind).validate(doc)
    if kind in ("experiment", "bounds"):
        assert doc["glintlab"] == 1
    assert _equal_given(raw, doc)
    assert json.loads(_core.parse_document(kind, json.dumps(doc), name)) == doc


def _equal_given(given, normalized):
    if isinstance(given, dict):
        return isinstance(normalized, dict) and all(k in normalized and _equal_given(v, normalized[k])
                                                    for k, v in given.items())
    if isinstance(given, list):
        return len(given) == len(normalized) and all(map(_equal_given, given, normalized))
    return given == normalized and type(given) in (type(normalized), float)


@pytest.mark.parametrize("name", BAD)
def test_bad_document(name):
    kind = kind_of(name)
    text = (DOCS / "bad" / name).read_text(encoding="utf-8")
    pointer, expected, got = cpp_error(kind, text, name)
    assert pointer == (EXPECTED[name] or "/")
    assert expected and got
    if name.startswith("syntax_"):
        with pytest.raises(json.JSONDecodeError):
            json.loads(text)
        return
    errors = list(validator(kind).iter_errors(json.loads(text)))
    if name.startswith("semantic_"):
        assert errors == [], "schema-valid by construction"
    else:
        assert errors, "jsonschema accepts what the C++ validator rejects"


def test_bad_corpus_exercises_every_keyword():
    # The keywords jsonschema reports on the schema-level bad files (oneOf failures counted with the
    # keywords of their branches).
    seen = set()

    def collect(errors):
        for e in errors:
            seen.add(e.validator)
            collect(e.context)

    for name in BAD:
        if not name.startswith(("semantic_", "syntax_")):
            collect(validator(kind_of(name)).iter_errors(json.loads((DOCS / "bad" / name).read_text())))
    assert seen >= {"type", "enum", "required", "additionalProperties", "minItems", "maxItems", "minLength",
                    "maxLength", "minimum", "maximum", "oneOf", "const", "exclusiveMinimum", "exclusiveMaximum"}


def test_defaults_are_filled_in():
    text = (DOCS / "good" / "experiment_law_forms.json").read_text()
    doc = json.loads(_core.parse_document("experiment", text, "x"))
    assert doc["laws"][0] == "binomial"
    assert doc["laws"][1] == {"name": "gaussian", "params": {}}
    assert doc["laws"][4] == {"name": "py", "python": "mod:fn", "n_uniforms": 2, "binning": "none"}
    assert doc["outputs"] == {"csv": True, "json": True, "plots": True}
    assert doc["reference"] == "binomial" and doc["samples"] is None and doc["seed"] == 1
    bounds = json.loads(_core.parse_document("bounds", (DOCS / "good" / "bounds_minimal.json").read_text(), "b"))
    assert bounds["bounds"][0]["regime"] == {"n": "standard", "p": "standard"}
    scene = json.loads(_core.parse_document("scene", (DOCS / "good" / "scene_plane_minimal.json").read_text(), "s"))
    assert scene["primitive"] == {"type": "plane", "uv_scale": 1.0, "point": [0, 0, 0], "normal": [0, 0, 1],
                                  "tilt_deg": 0}
    assert scene["material"] == {"ndf": "beckmann", "alpha": 1.0, "R": 0, "density": 0.5}
    assert scene["camera"]["fov_axis"] == "horizontal"


def test_message_format():
    with pytest.raises(ValueError, match=r"^exp\.json: at /laws/0/params/cap: expected a number or a string, got true$"):
        _core.parse_document("experiment", json.dumps({"laws": [{"name": "zk16", "params": {"cap": True}}],
                                                        "grid": {"n": [1], "p": [0.5]}}), "exp.json")
    pointer, expected, got = cpp_error("experiment", '{"laws": [tru]}', "e.json")
    assert pointer == "/" and expected.startswith("valid JSON (parse error at line 1")
    with pytest.raises(ValueError, match="unknown document kind"):
        _core.parse_document("nonsense", "{}", "x")


def test_messages_of_the_new_kinds():
    # A bad scene and a bad report configuration, in the one format (before: raw jsonschema text).
    scene = json.loads((DOCS / "good" / "scene_sphere.json").read_text())
    scene["material"]["R"] = 1.5
    with pytest.raises(ValueError, match=r"^s\.json: at /material/R: expected a number <= 1, got 1\.5$"):
        _core.parse_document("scene", json.dumps(scene), "s.json")
    scene["material"]["R"] = 0.5
    scene["primitive"]["normal"] = [0, 0, 1]
    assert cpp_error("scene", json.dumps(scene), "s.json") == (
        "/primitive/normal", "one of the fields center, radius, type, uv_scale", '"normal"')
    report = {"kind": "report", "sections": [{"name": "exact_laws", "parms": {}}]}
    assert cpp_error("report", json.dumps(report), "r.json") == (
        "/sections/0/parms", "one of the fields name, params, quick", '"parms"')


def test_python_parse_document():
    # validation.documents.parse_document: a path, JSON text or a dict, for every kind.
    path = DOCS / "good" / "scene_sphere.json"
    doc, name, base = documents.parse_document("scene", path)
    assert name == str(path) and base == path.resolve().parent and doc["camera"]["up"] == [0, 0, 1]
    assert documents.parse_document("scene", str(path))[0] == doc
    assert documents.parse_document("scene", path.read_text())[1:] == ("<scene>", None)
    assert documents.parse_document("report", {"kind": "report", "sections": [{"name": "x"}]})[1] == "<report>"
    with pytest.raises(ValueError, match=r"^<scene>: at /material/density: expected a finite number, got nan$"):
        documents.parse_document("scene", {**json.loads(path.read_text()), "material": {"density": float("nan")}})
    with pytest.raises(ValueError, match=r"^<report>: at /sections/0: expected a JSON value"):
        documents.parse_document("report", {"kind": "report", "sections": [{1, 2}]})
    with pytest.raises(ValueError, match="no such file"):
        documents.parse_document("scene", DOCS / "missing.json")
    with pytest.raises(ValueError, match="expected one of experiment, bounds, scene, report"):
        documents.parse_document("nonsense", {})
    from glintlab.validation import experiment
    assert experiment.parse_document is documents.parse_document


def _kind_of_shipped(path):
    if path.parent.name == "scenes":
        return "scene"
    if path.parent.name == "bounds":
        return "bounds"
    return "report" if json.loads(path.read_text()).get("kind") == "report" else "experiment"


@pytest.mark.parametrize("path", sorted((ROOT / "examples").glob("*.json")) +
                         sorted((ROOT / "python" / "glintlab" / "data").glob("bounds/*.json")) +
                         sorted((ROOT / "python" / "glintlab" / "data").glob("scenes/*.json")) +
                         sorted((ROOT / "python" / "glintlab" / "data").glob("report/*.json")), ids=lambda p: p.name)
def test_shipped_documents(path):
    kind = _kind_of_shipped(path)
    validator(kind).validate(json.loads(path.read_text()))
    _core.parse_document(kind, path.read_text(), path.name)


def test_random_mutations_agree_with_jsonschema():
    # Single-field mutations of the good documents: where jsonschema and the C++ validator could
    # disagree (integers, limits, unknown fields), both must call the same documents invalid.
    values = [None, True, 0, -1, 1.5, 2.0, 180, 1e300, "", "x", "standard", "sphere", "report", [], [0], [0, 1, 2],
              {}, {"name": "x"}, {"type": "plane"}]
    checked = 0
    for name in GOOD:
        kind = kind_of(name)
        base = json.loads((DOCS / "good" / name).read_text())
        for path in _paths(base):
            for value in values:
                doc = copy.deepcopy(base)
                _set(doc, path, value)
                schema_ok = not any(True for _ in validator(kind).iter_errors(doc))
                try:
                    _core.parse_document(kind, json.dumps(doc), name)
                    cpp_ok = True
                except _core.InputError as e:
                    cpp_ok = False
                    semantic = str(e)
                if schema_ok and not cpp_ok:
                    continue  # a rule beyond the schema may still reject it
                assert schema_ok == cpp_ok, (name, path, value, None if cpp_ok else semantic)
                checked += 1
    assert checked > 1000


def _paths(doc, prefix=()):
    if prefix:
        yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc[:3]):
            yield from _paths(v, prefix + (i,))


def _set(doc, path, value):
    for key in path[:-1]:
        doc = doc[key]
    doc[path[-1]] = value
