"""Monte Carlo dispersion campaigns (Gambone sec. III, Table 5, Figs 9-14).

* :mod:`~rcsim.analysis.campaign.spec` -- the TOML spec and its validation;
* :mod:`~rcsim.analysis.campaign.reader` -- reading a spec key by key, keys naming files;
* :mod:`~rcsim.analysis.campaign.limits` -- the physical ranges of spec values;
* :mod:`~rcsim.analysis.campaign.gate` -- the failure gate (``failure.max_failed_pct``);
* :mod:`~rcsim.analysis.campaign.schema` -- the runs.parquet columns (name, dtype, unit, meaning);
* :mod:`~rcsim.analysis.campaign.chunk` -- fly one chunk of runs, tabulate them (what workers run);
* :mod:`~rcsim.analysis.campaign.outcomes` -- a flown batch's outcome columns;
* :mod:`~rcsim.analysis.campaign.runner` -- local execution, streaming to disk, resume, interrupts;
* :mod:`~rcsim.analysis.campaign.cluster` -- Dask execution;
* :mod:`~rcsim.analysis.campaign.results` -- the campaign directory (chunks, runs.parquet,
  manifest);
* :mod:`~rcsim.analysis.campaign.replay` -- re-fly one run alone with its full history;
* :mod:`~rcsim.analysis.campaign.plots` -- Fig 9-14-like plots.

Imports ``models``, ``spacecraft``, ``lookup`` and the rest of ``analysis``; never
``rcsim.analysis.cli`` (the CLI imports this package, not the other way round).
"""
from rcsim.analysis.campaign.spec import EXAMPLE_SPEC, CampaignSpec, load_spec, parse_dict

__all__ = ["EXAMPLE_SPEC", "CampaignSpec", "load_spec", "parse_dict"]
