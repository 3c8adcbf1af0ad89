"""Monte Carlo dispersion campaigns (Gambone sec. III, Table 5, Figs 9-14).

* :mod:`~rcsim.analysis.engine.campaign.spec` -- the TOML spec and its validation;
* :mod:`~rcsim.analysis.engine.campaign.reader` -- reading a spec key by key, keys naming files;
* :mod:`~rcsim.analysis.engine.campaign.limits` -- the physical ranges of spec values;
* :mod:`~rcsim.analysis.engine.campaign.gate` -- the failure gate (``failure.max_failed_pct``);
* :mod:`~rcsim.analysis.engine.campaign.chunk` -- fly one chunk of runs, tabulate them
  (what workers run);
* :mod:`~rcsim.analysis.engine.campaign.outcomes` -- a flown batch's outcome columns;
* :mod:`~rcsim.analysis.engine.campaign.runner` -- local execution, streaming to disk, resume,
  interrupts;
* :mod:`~rcsim.analysis.engine.campaign.cluster` -- Dask execution;
* :mod:`~rcsim.analysis.engine.campaign.results` -- the campaign directory (chunks, runs.parquet,
  manifest);
* :mod:`~rcsim.analysis.engine.campaign.replay` -- re-fly one run alone with its full history;
* :mod:`~rcsim.analysis.engine.campaign.plots` -- Fig 9-14-like plots.

Imports ``models``, ``spacecraft``, ``lookup`` and the rest of the engine.

Must not import: rcsim.analysis.engine.scenarios.
"""

from rcsim.analysis.engine.campaign.spec import EXAMPLE_SPEC, CampaignSpec, load_spec, parse_dict

__all__ = ["EXAMPLE_SPEC", "CampaignSpec", "load_spec", "parse_dict"]
