"""Monte Carlo dispersion campaigns (Gambone sec. III, Table 5, Figs 9-14).

* :mod:`~analysis.campaign.spec` -- the TOML spec and its validation;
* :mod:`~analysis.campaign.chunk` -- fly one chunk of runs, tabulate outcomes (what workers run);
* :mod:`~analysis.campaign.runner` -- local / Dask execution, streaming to disk, resume;
* :mod:`~analysis.campaign.results` -- the campaign directory (chunks, runs.parquet, manifest);
* :mod:`~analysis.campaign.replay` -- re-fly one run alone with its full history;
* :mod:`~analysis.campaign.plots` -- Fig 9-14-like plots.
"""
from rcsim.analysis.campaign.spec import EXAMPLE_SPEC, CampaignSpec, load_spec, parse_dict

__all__ = ["EXAMPLE_SPEC", "CampaignSpec", "load_spec", "parse_dict"]
