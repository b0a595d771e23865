"""Success counts of executed plans and their 95% Clopper-Pearson intervals: ``rap.stats.Rate``
(their one home), named here for the robot's modules."""

from __future__ import annotations

from rap.stats import Rate, rate

__all__ = ["Rate", "rate"]
