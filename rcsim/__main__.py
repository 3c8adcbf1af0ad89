"""``python -m rcsim`` is the ``rcsim`` command."""

from rcsim.analysis.apps.cli import run

run()
