"""The engine that flies: scenarios and campaigns in, flights and their result files out.

* :mod:`~analysis.engine.flight` -- fly scenarios as one batch, history tables, flight plots;
* :mod:`~analysis.engine.scenarios` -- the paper's named scenarios;
* :mod:`~analysis.engine.campaign` -- Monte Carlo dispersion campaigns (spec, chunks, runner,
  Dask, resume, replay);
* :mod:`~analysis.engine.runs_table` -- ``runs.parquet`` and the campaign directory's file
  names: the one owner of the data contract between the engine and the results layer;
* :mod:`~analysis.engine.output` -- output directories and files (markers, atomic writes);
* :mod:`~analysis.engine.plots` -- plotting helpers without pyplot.

Must not import: analysis.results, analysis.apps.
"""
