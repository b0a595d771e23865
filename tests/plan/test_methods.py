"""The planning methods' declarations (rap.plan.methods, rap.plan.planners.options): one place that the
planner factory, the CLI's flags, the service's options and the experiment's names all read.
Every registered method is checked here, a new one included."""

from __future__ import annotations

import pytest

from rap.errors import InputError, ParameterError
from rap.plan.methods import (DEFAULT_METHOD, METHODS, PAPER_RAP, RapOptions, SearchOptions,
                              check_options, from_table_name, make_planner, method_options,
                              needs_model, option_named, service_options)
from rap.plan.planners.options import Option
from rap.plan.planners.base import Planner


@pytest.mark.parametrize("method", list(METHODS))
def test_every_method_is_declared_whole(method):
    options = METHODS[method]
    assert options.method == method and "-" not in method
    defaults = options()  # every default passes its own check
    planner = defaults.build()
    assert isinstance(planner, Planner) and planner.name == method
    assert vars(make_planner(method)) == vars(planner)
    assert defaults.table_name() == method
    assert vars(from_table_name(method).build()) == vars(planner)
    names = {o.name for o in options.declared()}
    for opt in options.declared():
        assert opt.kind in (int, float) and opt.help, opt
        text = opt.help_text(method, lambda n: f"<{n}>")  # every {name} it mentions is declared
        assert text.endswith("].") and "{" not in text
        assert {n for n in names if f"<{n}>" in text} <= names
        if opt.code:  # a letter, once per method
            assert len(opt.code) == 1 and opt.code_name
            assert [o.code for o in options.declared()].count(opt.code) == 1
    for suffix, values in options.presets.items():
        assert from_table_name(f"{method}-{suffix}") == options(**values)


def test_needs_model_and_the_default():
    assert {m for m in METHODS if needs_model(m)} == {"rap", "search"}
    assert needs_model("rap-k2") and not needs_model("optimal")
    assert DEFAULT_METHOD in METHODS and list(METHODS)[:5] == ["rap", "sim", "optimal", "random",
                                                                "search"]
    with pytest.raises(ParameterError, match="method 'bogus': choose one of rap, sim") as err:
        method_options("bogus")
    assert err.value.parameter == "method" and isinstance(err.value, InputError)


@pytest.mark.parametrize("given,message", [
    ({"fallback_k": 0}, "fallback_k 0: choose an integer >= 1"),
    ({"high_probability": 0.0}, r"high_probability 0.0: choose a probability in \(0, 1\]"),
    ({"high_probability": 1.5}, r"high_probability 1.5: choose a probability in \(0, 1\]"),
    ({"trust": 0}, r"trust 0: choose a score in \(0, 1\]"),
    ({"optimism": -0.1}, r"optimism -0.1: choose a number in \[0, 1\]"),
    ({"beam_width": 2.5}, "beam_width 2.5: choose an integer >= 1"),
    ({"simulations": True}, "simulations True: choose an integer >= 0"),
    ({"samples": 0}, "samples 0: choose an integer >= 1"),
    ({"bogus": 1}, "bogus 1: no planning method has this option"),
])
def test_options_are_checked_in_one_place_with_parameter_names(given, message):
    with pytest.raises(ParameterError, match=message):
        check_options(**given)
    name = next(iter(given))
    if name != "bogus":  # the planner factory checks the same way, for any method
        with pytest.raises(ParameterError, match=message):
            make_planner("sim", **given)


def test_given_options_of_other_methods_and_none_leave_the_defaults():
    rap = make_planner("rap", fallback_k=None, simulations=5, samples=3)
    assert (rap.fallback_k, rap.high_probability, rap.fallback_optimism) == (None, 0.9, 0.4)
    assert vars(make_planner("rap", **PAPER_RAP)) == vars(RapOptions(**PAPER_RAP).build())
    search = make_planner("search", simulations=200, optimism=0.1, fallback_k=2)
    assert (search.simulations, search.optimism, search.beam_width) == (200, 0.1, 8)
    assert make_planner("random", samples=7).samples == 7


def test_experiment_names_read_and_written():
    opts = from_table_name("rap-k2-p90")
    assert opts == RapOptions(fallback_k=2, high_probability=0.9)
    assert opts.table_name() == "rap-k2"  # p90 is the default
    assert from_table_name("rap-paper").table_name() == "rap-paper"
    s = from_table_name("search-s200-o10")
    assert s == SearchOptions(simulations=200, optimism=0.1) and s.table_name() == "search-o10"
    assert from_table_name("search-t97").trust == 0.97
    assert from_table_name("random", samples=5).samples == 5
    for bad, why in (("rap-k2-k3", "rap options are -kK"), ("rap-p0", "P must lie in 1..100"),
                     ("search-b0", "OPS must be >= 1"), ("random-s3", "random takes no options"),
                     ("nope-k1", "choose one of rap")):
        with pytest.raises(ParameterError, match=why):
            from_table_name(bad)
    with pytest.raises(ValueError, match="no experiment method name"):
        SearchOptions(trust=0.975).table_name()  # not a whole percentage


def test_search_defaults_and_the_previous_default_round_trip():
    d = SearchOptions()
    assert (d.simulations, d.upper, d.confidence, d.gap) == (200, 0.35, 0.95, 0.0)
    assert d.table_name() == "search" and from_table_name("search") == d
    old = from_table_name("search-s0-u0")  # the default before the bounds (issue 30)
    assert old == SearchOptions(simulations=0, upper=0.0, gap=0.0)
    assert old.table_name() == "search-s0-u0"
    tight = from_table_name("search-g5")  # the default, simulating on until within 5% of V
    assert tight == SearchOptions(gap=0.05) and tight.table_name() == "search-g5"
    assert from_table_name("search-s0").table_name() == "search-s0"  # the same plans (no sims)
    planner = old.build()
    assert (planner.simulations, planner.upper, planner.optimism, planner.gap) == (0, 0.0, 0.0,
                                                                                   None)
    assert make_planner("search", gap=0.0).gap is None  # 0: off, as the planner's None
    assert make_planner("search", gap=None).gap is None  # None: not given, the default (off)
    assert make_planner("search", gap=0.05).gap == 0.05


def test_the_service_takes_the_declared_options_default_method_first():
    accepted = service_options()
    assert list(accepted) == ["simulations", "trust", "optimism", "upper", "confidence", "gap",
                              "time_limit", "greedy_from", "improve", "beam_from", "window",
                              "beam_width",
                              "fallback_k", "high_probability", "fallback_optimism"]  # not samples, b
    assert accepted["trust"][1] == ("search",) and accepted["fallback_k"][1] == ("rap",)
    method, opt = option_named("optimism")
    assert method == "search" and isinstance(opt, Option) and (opt.low, opt.high) == (0.0, 1.0)
    assert opt.help_text(method, lambda n: "--" + n).startswith("Method search with --simulations")
