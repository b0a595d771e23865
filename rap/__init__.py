"""rap-farm: robust 2D assembly sequencing (Geft, Tamar, Goldberg, Halperin) as a labelling farm.

Layers import downward only: ``geometry`` (exact) <- ``sim``/``render`` (floats) <- ``model`` (torch)
<- ``plan``; only ``farm`` imports ray, and the CLI imports it lazily.
"""

__version__ = "0.5.0"
