"""Failure drivers: which dispersed inputs make Monte Carlo runs fail (a TRAM-like analysis).

Owns reading runs (:mod:`.inputs`; of a large table only the rows analysed, :mod:`.reading`),
physics-aware derived factors (:mod:`.factors`), the
rank-scale KDE engine (:mod:`.kde`), single-factor and pair estimators (:mod:`.single`,
:mod:`.pairs`), half-sample stability (:mod:`.stability`), kNN failure maps (:mod:`.maps`),
the random forest's ranking for comparison (:mod:`.second_opinion`), the t-test baseline
(:mod:`.baseline`), planted-truth campaigns (:mod:`.synthetic`), the whole analysis
(:mod:`.pipeline`), the one false-flag budget over every flag it shows (:mod:`.findings`),
the counted figures and sentences of "How the runs fail" (:mod:`.mechanism`,
:mod:`.mechanism_text`), PRIM boxes (:mod:`.prim`, :mod:`.boxes`, :mod:`.box_analysis`), its
figures and its outputs.  Estimators follow scikit-learn
(``__init__`` stores, ``fit`` returns self, learned attributes end in ``_``, ``random_state``).
Reads campaign outputs (through :mod:`rcsim.analysis.engine.runs_table`) and uses
``spacecraft``/``models`` for the vehicle geometry; report sections through the generic kit
:mod:`rcsim.analysis.results.report`.

Must not import: rcsim.analysis.engine.campaign, rcsim.analysis.engine.flight, rcsim.analysis.apps.
"""
