"""Labelling without Ray: what a label run takes and the rows it writes.

* ``rap.labelling.selection``: ``LabelConfig``, ``prepare`` (every input checked, the dataset's
  lock taken, each assembly's selection decided), ``select_jobs``/``iter_jobs`` (the operations not
  yet in the dataset, with their content keys and seeds), ``LabelSummary``;
* ``rap.labelling.rows``: ``Backend`` (the simulator and renderer by import path), ``label_rows``
  (one batch's rows) and ``rows_table`` (them as one Arrow table).

The operations come from ``rap.enumerate`` and the rows go to ``rap.dataset``; ``rap.farm`` runs
all of it on Ray (``rap.farm.driver``), and ``scripts/label_burst.py`` in a plain process pool.
"""
