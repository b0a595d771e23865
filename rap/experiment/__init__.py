"""The planning experiment: planners compared on held-out assemblies, robustness against planning time (``run``), and its table, JSON and chart (``report``). Layer above rap.plan; no ray."""
