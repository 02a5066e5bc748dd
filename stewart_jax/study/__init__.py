"""Reproductions of the papers' simulation studies, as seeded Monte Carlo runs.

:func:`run_study` is Wang et al. (2018) §3, Table 2 ("Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5)): chunked,
checkpointed, resumable and split over devices or hosts.
"""

from ._study import (
    BEFORE as BEFORE,
    METHOD_LABELS as METHOD_LABELS,
    PAPER_TABLE2 as PAPER_TABLE2,
    format_study_table as format_study_table,
    run_study as run_study,
    simulate_trials as simulate_trials,
    trial_keys as trial_keys,
)
