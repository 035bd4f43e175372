"""Tuning: what may change (``tunable``), the tasks whose lost time is minimised
(``tasks``), the search for the most productive verified configuration (``tuner``)
and its report (``report``)."""
