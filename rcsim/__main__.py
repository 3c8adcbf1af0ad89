"""``python -m rcsim`` is the ``rcsim`` command."""

import sys

from rcsim._layers import check_layers

try:
    check_layers()
except ImportError as exc:
    print(f"rcsim: error: {str(exc).removeprefix('rcsim: ')}", file=sys.stderr)
    sys.exit(2)

from analysis.apps.cli import run  # noqa: E402 - only once the layers are rcsim's

run()
