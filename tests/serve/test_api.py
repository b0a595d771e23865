"""The planning service's contract without a service: request parsing and start-up checks."""

from __future__ import annotations

import json

import pytest

from rap.assembly import assembly_to_json
from rap.errors import InputError
from rap.serve.api import BadRequest, ServeConfig, is_loopback, parse_plan_body, parse_plan_request
from rap.serve.budget import anytime_limits
from rap.geometry.families.simple import grid
from rap.seeds import DEFAULT_ROOT_SEED

SQUARES = {"name": "two", "parts": [{"id": "a", "polygon": [[0, 0], [1, 0], [1, 1], [0, 1]]},
                                    {"id": "b", "polygon": [[1, 0], [2, 0], [2, 1], [1, 1]]}]}


def test_a_request_is_read_exactly():
    text = ('{"assembly": {"parts": [{"id": "a", "polygon": [[0, 0], [0.1, 0], [0.1, 1], [0, 1]]},'
            '{"id": "b", "polygon": [[0.1, 0], [0.3, 0], [0.3, 1], [0.1, 1]]}]}, "seed": -4}')
    asm, method, seed, options, _ = parse_plan_request(text.encode())
    assert (asm.name, method, seed) == ("assembly", "search", -4)  # the default method
    assert str(asm.part("a").outer[1][0]) == "1/10"  # a decimal, not the float 0.1
    asm, method, seed, options, _ = parse_plan_request(json.dumps({"assembly": SQUARES,
                                                                "method": "optimal"}).encode())
    assert (asm.name, method, seed, options) == ("two", "optimal", DEFAULT_ROOT_SEED, {})


def test_planner_options_are_read_for_their_method():
    body = {"assembly": SQUARES, "options": {"simulations": 200, "optimism": 0.1, "trust": 1}}
    _, method, _, options, _ = parse_plan_request(json.dumps(body).encode())
    assert method == "search" and options == {"simulations": 200, "optimism": 0.1, "trust": 1.0}
    assert all(type(options[k]) is float for k in ("optimism", "trust"))
    body = {"assembly": SQUARES, "method": "rap",
            "options": {"fallback_k": 2, "high_probability": 0.8}}
    assert parse_plan_request(json.dumps(body).encode())[3] == {"fallback_k": 2,
                                                               "high_probability": 0.8}


def _with_options(options, method="search"):
    return json.dumps({"assembly": SQUARES, "method": method, "options": options}).encode()


@pytest.mark.parametrize("body,status,needle", [
    (_with_options([1]), 400, "options must be a JSON object"),
    (_with_options({"budget": 3}), 400, "unknown option 'budget'"),
    (_with_options({"trust": 0.9}, "rap"), 400, "options.trust applies to method search"),
    (_with_options({"fallback_k": 2}, "sim"), 400, "applies to method rap"),
    (_with_options({"simulations": 1.5}), 400, "must be an integer"),
    (_with_options({"simulations": True}), 400, "must be an integer"),
    (_with_options({"optimism": "high"}), 400, "must be a number"),
    (_with_options({"optimism": 1.5}), 400, "must lie in [0.0, 1.0]"),
    (_with_options({"trust": 0}), 400, "must lie in (0.0, 1.0]"),
    (_with_options({"beam_width": 0}), 400, "must be >= 1"),
    (_with_options({"simulations": 2001}), 413, "at most 2000"),
])
def test_bad_planner_options_are_one_line(body, status, needle):
    with pytest.raises(BadRequest) as exc:
        parse_plan_request(body)
    assert exc.value.status == status and needle in exc.value.message, exc.value.message
    assert "\n" not in exc.value.message


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


def test_a_hundred_part_drawing_is_a_question_not_a_refusal():
    """The service plans what the input bounds allow (issue 37): a 100-part grid is parsed, and
    only an assembly past ``max_parts`` (the input bounds by default) is refused with 413."""
    import json as _json

    from rap.assembly import LIMITS, assembly_to_json
    from rap.geometry.families.simple import grid
    from rap.serve.api import ServeConfig

    body = _json.dumps({"assembly": assembly_to_json(grid(10)), "method": "search"}).encode()
    assert len(parse_plan_request(body)[0]) == 100
    assert ServeConfig().max_parts == LIMITS.max_parts
    with pytest.raises(BadRequest) as err:
        parse_plan_request(body, max_parts=64)
    assert err.value.status == 413 and "100 parts" in err.value.message


def test_a_request_budget_defaults_to_the_services_and_stays_within_its_cap():
    body = {"assembly": SQUARES}
    assert parse_plan_body(json.dumps(body).encode()).budget_s == ServeConfig.request_budget_s
    assert parse_plan_body(json.dumps(body).encode(), default_budget_s=30.0).budget_s == 30.0
    got = parse_plan_body(json.dumps({**body, "budget_s": 7.5}).encode(), max_budget_s=10.0)
    assert got.budget_s == 7.5 and type(got.budget_s) is float
    for bad, status in ((0, 400), (-1, 400), ("60", 400), (True, 400), (10.5, 413)):
        with pytest.raises(BadRequest) as err:
            parse_plan_body(json.dumps({**body, "budget_s": bad}).encode(), max_budget_s=10.0)
        assert err.value.status == status and "budget_s" in err.value.message


def test_the_search_gets_the_budget_less_the_evaluations_share_as_its_time_limit():
    # (options, hard seconds): the search's hard budget is the answer's deadline
    assert anytime_limits("search", {}, 120.0, 0.25, 30.0) == ({"time_limit": 90.0}, 150.0)
    # a request's own time limit, when smaller, wins; its 0 ("no limit") is the budget's
    assert anytime_limits("search", {"time_limit": 5.0}, 120.0, 0.25, 30)[0]["time_limit"] == 5.0
    assert anytime_limits("search", {"time_limit": 0.0}, 8.0, 0.25, 30)[0]["time_limit"] == 6.0
    assert anytime_limits("search", {"time_limit": 500.0}, 8.0, 0.25, 30)[0]["time_limit"] == 6.0
    # methods without a time limit keep their options and the request's budget as a hard one
    assert anytime_limits("sim", {}, 120.0, 0.25, 30.0) == ({}, 120.0)
    assert anytime_limits("rap", {"fallback_k": 2}, 120.0, 0.25, 30.0) == ({"fallback_k": 2}, 120.0)


def test_the_service_scores_as_the_cli_does_by_default():
    assert ServeConfig().engine == "auto"
    with pytest.raises(InputError, match="--engine"):
        ServeConfig(engine="onnx").check()
    with pytest.raises(InputError, match="--budget"):
        ServeConfig(request_budget_s=900.0).check()
