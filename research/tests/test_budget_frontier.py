"""``research.budget_frontier``: the settings compared and the summary's ratios."""

from __future__ import annotations

from research.budget_frontier import _settings, summary


def test_small_band_budgets_follow_the_graph_size():
    s = _settings("small", 300)
    assert s["base"] == {} and s["s10"] == {"simulations": 30} and s["s07"] == {"simulations": 21}
    assert _settings("small", 3)["s07"] == {"simulations": 1}  # never a zero budget
    assert s["g05"] == {"gap": 0.05} and s["g05s600"] == {"gap": 0.05, "simulations": 600}


def test_the_summary_covers_the_settings_measured():
    rows = [{"reference": [0.5, 2.0, 10], "base": [0.5, 1.0, 5], "g05": [0.4, 1.0, 6]}]
    lines = summary(rows, "small")
    assert [line.split()[0] for line in lines] == ["base", "g05"]
    assert "min 0.800" in lines[1] and "below 0.95: 1 of 1" in lines[1]


def test_summary_divides_by_the_reference_and_counts_the_misses():
    rows = [{"reference": [0.8, 10.0, 100], **{k: [0.8 * f, t, 5] for k in _settings("small", 10)}}
            for f, t in ((1.0, 1.0), (0.9, 4.0))]
    base = next(line for line in summary(rows, "small") if line.startswith("base"))
    assert "min 0.900 mean 0.950 (below 0.95: 1 of 2)" in base
    assert "time/ref max 0.40 geometric mean 0.200" in base


def test_mid_summary_compares_with_the_search_without_greedys_start():
    names = _settings("mid", None)
    row = {"reference": [0.1, 2.0, 10], **{k: [0.2, 4.0, 20] for k in names}}
    row["nostart"] = [0.25, 6.0, 30]
    lines = summary([row], "mid")
    assert any(line.startswith("i100") and "R/nostart geometric mean 0.800" in line
               and "time/ref max 2.00" in line for line in lines)


def test_mid_band_compares_with_the_cnn_alone_and_needs_no_nostart_row():
    assert _settings("mid", None)["cnn"] == {"engine": "cnn"}
    rows = [{"reference": [0.1, 2.0, 10], "i100": [0.2, 4.0, 20], "cnn": [0.25, 6.0, 30]}]
    lines = summary(rows, "mid")
    assert [line.split()[0] for line in lines] == ["i100", "cnn"]
    assert "R/nostart" not in " ".join(lines)
