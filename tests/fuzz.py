"""Hypothesis strategies for hostile assembly input: JSON text that a careless user or an attacker
sends (shared by tests/test_fuzz_inputs.py and the service's fuzz test in tests/serve/test_http_app.py).

``assembly_texts()`` draws the text of an assembly file: a valid base assembly with one or more
mutations (a coordinate replaced by an adversarial number, a value of the wrong type, a duplicate
id, a removed or unknown key, deep nesting, truncation, binary junk). ``plan_bodies()`` wraps such a
text into a ``POST /plan`` body, with a method, seed and options drawn as hostile too. Everything is
text, spliced as is, so numbers such as ``1e-1000000`` reach the parser untouched.
"""

from __future__ import annotations

import json

from hypothesis import strategies as st

BASE = {"name": "fuzz", "parts": [
    {"id": "a", "polygon": [[0, 0], [4, 0], [4, 2], [0, 2]]},
    {"id": "b", "polygon": [[0, 2], [4, 2], [2, 5]], "holes": []},
    {"id": "c", "polygon": [[4, 0], [7, 0], [7, 5], [4, 5]], "holes": [[[5, 1], [6, 1], [6, 2]]]},
]}

#: numbers as they may stand in a file: past every bound, at the bounds, not numbers at all
NUMBER_TEXTS = [
    "1e-1000000", "1e10000000", "-1e10000000", "1e309", "-1e309", "4.9e-324", "1e-7",
    "0." + "0" * 5000 + "1", "1" * 4000, "1" * 5000, "1." + "0" * 100000, "0e99999999",
    "1000000000", "-1000000000", "1000000000.000001", "999999999.999999", "0.000001", "-0",
    "-0.0", "2.5e-6", "1e9", "1E+9", "NaN", "Infinity", "-Infinity", "1e", "--1", "0x10",
    "true", "null", "\"3\"", "[]", "{}",
]

#: values of the wrong type for any key
WRONG_VALUES = ["null", "true", "false", "0", "-1", "\"\"", "\"x\"", "[]", "{}", "[[]]",
                "[1, 2]", "\"" + "a" * 300 + "\"", "1e400"]


def _paths(doc, prefix=()):
    """Every path (tuple of keys and indices) into a JSON document."""
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


_PLACEHOLDER = "\"__fuzz_placeholder__\""


def _replace_at(doc, path, raw: str) -> str:
    """The JSON text of ``doc`` with the value at ``path`` replaced by the raw text ``raw``."""
    if not path:
        return raw
    doc = json.loads(json.dumps(doc))
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = "__fuzz_placeholder__"
    return json.dumps(doc).replace(_PLACEHOLDER, raw, 1)


@st.composite
def assembly_texts(draw) -> str:
    """The text of a hostile assembly file (see module doc)."""
    kind = draw(st.sampled_from(["number", "number", "wrong", "duplicate", "drop", "unknown",
                                 "nest", "truncate", "binary", "many", "decimal"]))
    doc = json.loads(json.dumps(BASE))
    if kind == "number":
        path = draw(st.sampled_from([p for p in _paths(doc) if _is_number(_get(doc, p))]))
        return _replace_at(doc, path, draw(st.sampled_from(NUMBER_TEXTS)))
    if kind == "decimal":
        path = draw(st.sampled_from([p for p in _paths(doc) if _is_number(_get(doc, p))]))
        value = draw(st.decimals(allow_nan=True, allow_infinity=True, places=None))
        return _replace_at(doc, path, str(value) if value.is_finite() else "NaN")
    if kind == "wrong":
        path = draw(st.sampled_from(list(_paths(doc))))
        return _replace_at(doc, path, draw(st.sampled_from(WRONG_VALUES)))
    if kind == "duplicate":
        doc["parts"][1]["id"] = doc["parts"][0]["id"]
        return json.dumps(doc)
    if kind == "drop":
        dicts = [p for p in _paths(doc) if isinstance(_get(doc, p), dict) and _get(doc, p)]
        path = draw(st.sampled_from(dicts))
        node = _get(doc, path)
        node.pop(draw(st.sampled_from(sorted(node))))
        return json.dumps(doc)
    if kind == "unknown":
        doc["parts"][0][draw(st.text(min_size=1, max_size=8))] = 1
        return json.dumps(doc)
    if kind == "nest":
        depth = draw(st.integers(10, 200_000))
        inner = draw(st.sampled_from(["0", "[0, 0]", json.dumps(BASE["parts"][0])]))
        nested = "[" * depth + inner + "]" * depth
        where = draw(st.sampled_from(["top", "parts", "polygon"]))
        if where == "top":
            return nested
        if where == "parts":
            return "{\"parts\": " + nested + "}"
        return "{\"parts\": [{\"id\": \"a\", \"polygon\": " + nested + "}]}"
    if kind == "truncate":
        text = json.dumps(doc)
        return text[:draw(st.integers(0, len(text) - 1))]
    if kind == "binary":
        return draw(st.binary(min_size=0, max_size=200)).decode("latin-1")
    # many: a part or a ring far past the bounds (parts, vertices)
    n = draw(st.integers(1001, 3000))
    if draw(st.booleans()):
        parts = [{"id": f"p{i}", "polygon": [[i, 0], [i + 1, 0], [i + 1, 1]]} for i in range(n)]
        return json.dumps({"parts": parts})
    ring = [[i, i * i % 7] for i in range(10 * n)]
    return json.dumps({"parts": [{"id": "a", "polygon": ring}]})


def _get(doc, path):
    for key in path:
        doc = doc[key]
    return doc


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@st.composite
def plan_bodies(draw) -> bytes:
    """A hostile ``POST /plan`` body: a hostile assembly, method, seed and options."""
    assembly = draw(assembly_texts())
    fields = ["\"assembly\": " + assembly]
    if draw(st.booleans()):
        fields.append("\"method\": " + draw(st.sampled_from(
            ["\"sim\"", "\"optimal\"", "\"nosuch\"", "1", "null", "[\"sim\"]"])))
    if draw(st.booleans()):
        fields.append("\"seed\": " + draw(st.sampled_from(
            ["1", "-1", "1e3", "1.5", "true", "\"7\"", "9" * 30, "1e-1000000"])))
    if draw(st.booleans()):
        fields.append("\"options\": " + draw(st.sampled_from(
            ["{}", "{\"simulations\": 1e10000000}", "{\"trust\": NaN}", "{\"nosuch\": 1}",
             "{\"simulations\": -1}", "[]", "{\"optimism\": 1e-1000000}"])))
    if draw(st.integers(0, 9)) == 0:
        fields.append("\"extra\": 1")
    body = "{" + ", ".join(fields) + "}"
    if draw(st.integers(0, 9)) == 0:
        body = body[:draw(st.integers(0, len(body)))]
    return body.encode("utf-8", "surrogatepass")
