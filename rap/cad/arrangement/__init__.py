"""Drawings whose parts are not one closed loop each: what is annotation, and parts as faces.

Modules, one family each: ``annotations`` (the paths an import leaves out and why: construction
and dimension lines, shapes drawn twice, outlines of the parts' union, frames, symbols),
``faces`` (parts as the faces of cut lines drawn once, noded with snap rounding), ``overlay``
(hand-placed loops overlapping by less than the tolerance, each overlap given to one piece).
Floats (shapely/GEOS) decide what is what; every part comes out as exact grid indices, validated
exactly by ``rap.cad.importer``.
"""
