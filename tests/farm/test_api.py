"""The planning service's contract without a service: request parsing and start-up checks."""

from __future__ import annotations

import json

import pytest

from rap.assembly import assembly_to_json
from rap.errors import InputError
from rap.farm.api import BadRequest, ServeConfig, is_loopback, parse_plan_request
from rap.geometry.generate import grid
from rap.seeds import DEFAULT_ROOT_SEED

SQUARES = {"name": "two", "parts": [{"id": "a", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]]},
                                    {"id": "b", "polygon": [[1, 0], [2, 0], [2, 1], [1, 1]]}]}


def test_a_request_is_read_exactly():
    text = ('{"assembly": {"parts": [{"id": "a", "polygon": [[0, 0], [0.1, 0], [0.1, 1], [0, 1]]},'
            '{"id": "b", "polygon": [[0.1, 0], [0.3, 0], [0.3, 1], [0.1, 1]]}]}, "seed": -4}')
    asm, method, seed = parse_plan_request(text.encode())
    assert (asm.name, method, seed) == ("assembly", "search", -4)  # the default method
    assert str(asm.part("a").outer[1][0]) == "1/10"  # a decimal, not the float 0.1
    asm, method, seed = parse_plan_request(json.dumps({"assembly": SQUARES,
                                                       "method": "optimal"}).encode())
    assert (asm.name, method, seed) == ("two", "optimal", DEFAULT_ROOT_SEED)


@pytest.mark.parametrize("body,status,needle", [
    (b"{", 400, "not valid JSON"),
    (b"\xff\xfe", 400, "not valid JSON"),
    (b"{\"assembly\": NaN}", 400, "not valid JSON"),
    (b"null", 400, "JSON object"),
    (json.dumps({"assembly": SQUARES, "x": 1}).encode(), 400, "unknown key 'x'"),
    (json.dumps({"method": "rap"}).encode(), 400, "missing key 'assembly'"),
    (json.dumps({"assembly": SQUARES, "method": 3}).encode(), 400, "method 3"),
    (json.dumps({"assembly": SQUARES, "seed": 2 ** 63}).encode(), 400, "seed"),
    (json.dumps({"assembly": []}).encode(), 400, "assembly: top level must be"),
    (json.dumps({"assembly": {"parts": [SQUARES["parts"][0]] * 2}}).encode(), 400,
     "assembly: part 'a': duplicate id"),
    (json.dumps({"assembly": assembly_to_json(grid(9))}).encode(), 413, "81 parts"),
    (json.dumps({"assembly": assembly_to_json(grid(5)), "method": "optimal"}).encode(), 413,
     "optimal"),
])
def test_bad_requests_are_one_line(body, status, needle):
    with pytest.raises(BadRequest) as exc:
        parse_plan_request(body)
    assert exc.value.status == status and needle in exc.value.message
    assert "\n" not in exc.value.message


@pytest.mark.parametrize("host,ok", [("127.0.0.1", True), ("127.0.0.2", True), ("::1", True),
                                     ("localhost", True), ("0.0.0.0", False), ("10.0.0.5", False),
                                     ("::", False), ("example.org", False)])
def test_only_loopback_is_served_without_a_token(host, ok):
    assert is_loopback(host) is ok
    if ok:
        ServeConfig(host=host).check()
    else:
        with pytest.raises(InputError, match="token"):
            ServeConfig(host=host).check()
        ServeConfig(host=host, token="t" * 16).check()
    with pytest.raises(InputError, match="16 characters"):
        ServeConfig(host=host, token="short").check()
    assert "token" not in ServeConfig(token="t" * 20).to_dict()
