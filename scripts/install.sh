#!/usr/bin/env bash
# Install rap-farm into the active Python environment.
#   bash scripts/install.sh          # the package and its CLI
#   bash scripts/install.sh --test   # plus the test tools
# torch: if no torch is installed yet, install the pinned CPU build first so that resolving the
# package's `torch>=2.2` requirement pulls nothing more (an unpinned torch would pull several GB of
# CUDA packages). Set RAP_TORCH_INDEX=https://download.pytorch.org/whl/cpu where the pinned wheel
# on your package index is a CUDA build; bring your own torch (e.g. CUDA) by installing it first.
set -euo pipefail
cd "$(dirname "$0")/.."
extra=""
[ "${1:-}" = "--test" ] && extra="[test]"
python -m pip install -q --upgrade pip
if ! python -c "import torch" >/dev/null 2>&1; then
  if [ -n "${RAP_TORCH_INDEX:-}" ]; then
    python -m pip install -q "torch==2.13.0" --index-url "$RAP_TORCH_INDEX"
  else
    python -m pip install -q "torch==2.13.0"
  fi
fi
python -m pip install -q -e ".${extra}"
# the planning page's browser tests drive Debian's chromium through Playwright (its own browser
# download does not work offline); without it they skip and say so
if [ -n "$extra" ] && ! command -v chromium >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
      || echo "no chromium: the browser tests will skip"
  else
    echo "no chromium (apt-get install chromium as root): the browser tests will skip"
  fi
fi
echo "rap-farm installed: $(command -v rap-farm)"
