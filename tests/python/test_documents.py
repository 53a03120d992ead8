"""Experiment and bounds documents: the C++ validator (_core.parse_document) against Debian's
python3-jsonschema on a corpus of good and bad documents (tests/data/documents).

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

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "tests" / "data" / "documents"
SCHEMAS = {kind: json.loads((ROOT / "python" / "glintlab" / "data" / "schema" / f"{kind}.schema.json").read_text())
           for kind in ("experiment", "bounds")}
EXPECTED = json.loads((DOCS / "bad" / "expected.json").read_text())
GOOD = sorted(p.name for p in (DOCS / "good").glob("*.json"))
BAD = sorted(p.name for p in (DOCS / "bad").glob("*.json") if p.name != "expected.json")


def validator(kind):
    # bounds.schema.json refers to "experiment.schema.json#/definitions/...", relative to its $id.
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
    assert {kind_of(n) for n in GOOD + BAD} == {"experiment", "bounds"}


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
                    "maxLength", "minimum", "maximum", "oneOf"}


def test_defaults_are_filled_in():
    text = (DOCS / "good" / "experiment_law_forms.json").read_text()
    doc = json.loads(_core.parse_document("experiment", text, "x"))
    assert doc["laws"][0] == "binomial"
    assert doc["laws"][1] == {"name": "gaussian", "params": {}}
    assert doc["laws"][4] == {"name": "py", "python": "mod:fn", "n_uniforms": 2}
    assert doc["outputs"] == {"csv": True, "json": True, "plots": True}
    assert doc["reference"] == "binomial" and doc["samples"] is None and doc["seed"] == 1
    bounds = json.loads(_core.parse_document("bounds", (DOCS / "good" / "bounds_minimal.json").read_text(), "b"))
    assert bounds["bounds"][0]["regime"] == {"n": "standard", "p": "standard"}


def test_message_format():
    with pytest.raises(ValueError, match=r"^exp\.json: at /laws/0/params/cap: expected a number or a string, got true$"):
        _core.parse_document("experiment", json.dumps({"laws": [{"name": "zk16", "params": {"cap": True}}],
                                                        "grid": {"n": [1], "p": [0.5]}}), "exp.json")
    pointer, expected, got = cpp_error("experiment", '{"laws": [tru]}', "e.json")
    assert pointer == "/" and expected.startswith("valid JSON (parse error at line 1")
    with pytest.raises(ValueError, match="unknown document kind"):
        _core.parse_document("nonsense", "{}", "x")


def _is_report_config(path):
    return json.loads(path.read_text()).get("kind") == "report"  # glintlab report's sections (test_report.py)


@pytest.mark.parametrize("path", [p for p in sorted((ROOT / "examples").glob("*.json")) if not _is_report_config(p)] +
                         sorted((ROOT / "python" / "glintlab" / "data").glob("bounds/*.json")), ids=lambda p: p.name)
def test_shipped_documents(path):
    kind = "experiment" if path.parent.name == "examples" else "bounds"
    validator(kind).validate(json.loads(path.read_text()))
    _core.parse_document(kind, path.read_text(), path.name)


def test_random_mutations_agree_with_jsonschema():
    # Single-field mutations of the good documents: where jsonschema and the C++ validator could
    # disagree (integers, limits, unknown fields), both must call the same documents invalid.
    values = [None, True, 0, -1, 1.5, 2.0, 1e300, "", "x", "standard", [], [0], [0, 1, 2], {}, {"name": "x"}]
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
