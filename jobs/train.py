"""Ray Job entrypoint: `rap-farm train ...` on the cluster the job was submitted to.

    ray job submit --address http://127.0.0.1:8265 --working-dir . -- \
        python jobs/train.py ARGS...

Inside a Ray Job, RAY_ADDRESS points at the cluster, so the command joins it (it never starts a
second Ray). Arguments are those of `rap-farm train --help`. See jobs/README.md.
"""

import sys

from rap.cli import main

if __name__ == "__main__":
    main(["train", *sys.argv[1:]])
