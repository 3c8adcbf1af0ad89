"""``python -m rcsim.analysis.cli`` is ``rcsim``."""
import sys

from rcsim.analysis.cli import main

sys.exit(main())
