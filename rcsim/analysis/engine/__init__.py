"""The engine that flies: scenarios and campaigns in, flights and their result files out.

* :mod:`~rcsim.analysis.engine.flight` -- fly scenarios as one batch, history tables, flight plots;
* :mod:`~rcsim.analysis.engine.scenarios` -- the paper's named scenarios;
* :mod:`~rcsim.analysis.engine.campaign` -- Monte Carlo dispersion campaigns (spec, chunks, runner,
  Dask, resume, replay);
* :mod:`~rcsim.analysis.engine.rare` -- rare-event estimation (subset simulation) of a margin
  evaluated in batches, generic numpy (a campaign adapter flies the batches);
* :mod:`~rcsim.analysis.engine.runs_table` -- ``runs.parquet`` and the campaign directory's file
  names: the one owner of the data contract between the engine and the results layer;
* :mod:`~rcsim.analysis.engine.output` -- output directories and files (markers, atomic writes),
  with the record of what a command wrote (:mod:`~rcsim.analysis.engine.output_records`),
  where an output may go (:mod:`~rcsim.analysis.engine.output_places`), one lock per real
  output path (:mod:`~rcsim.analysis.engine.locks`) and files committed together
  (:mod:`~rcsim.analysis.engine.commit`);
* :mod:`~rcsim.analysis.engine.pool_guard` -- worker processes that die with rcsim;
* :mod:`~rcsim.analysis.engine.plots` -- plotting helpers without pyplot.

Must not import: rcsim.analysis.results, rcsim.analysis.apps.
"""
