"""Finding counterexamples: the two evaluators of a scenario (the batched closed loop,
``evaluate_batch``, and the Drake diagram, ``evaluate_drake``), the runner that
parallelises and caches them, the ranking models, the sweeps and the falsifier
(``strategies``) and the count of every model evaluation (``counts``)."""
