"""Run ``rap-farm`` with the test stand-ins for layers that do not exist yet (test helper).

``python tests/farm/cli_standins.py label ...``: like ``rap-farm label ...``, but when
``rap.render.images`` is missing the workers render with ``tests.farm.standin.render``.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

if __name__ == "__main__":
    import rap.farm.driver as driver
    from rap.cli import main

    if importlib.util.find_spec("rap.render.images") is None:
        from rap.farm.actors import Backend

        _run = driver.run_label
        backend = Backend(render="tests.farm.standin:render")

        def run_label(cfg, plan=None, **kw):
            return _run(dataclasses.replace(cfg, backend=backend), plan, **kw)

        driver.run_label = run_label
    main(sys.argv[1:])
