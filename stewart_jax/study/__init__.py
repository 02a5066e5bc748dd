"""Reproductions of the papers' simulation studies, as seeded Monte Carlo runs.

:func:`run_study` is Wang et al. (2018) §3, Table 2 ("Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5)): chunked,
checkpointed, resumable and split over devices or hosts. The statistics of method comparisons
over seeds: :func:`paired_comparison` (Wilcoxon signed-rank test and the bootstrap interval of
the median ratio), :func:`data_profiles` (Moré–Wild) and :func:`best_within_budgets` (budget
curves); :func:`simulate_trials` and :func:`trial_keys` give the study's trials to other methods.
"""


from ._statistics import (
    best_within_budgets as best_within_budgets,
    data_profiles as data_profiles,
    paired_comparison as paired_comparison,
)
from ._study import (
    PAPER_TABLE2 as PAPER_TABLE2,
    format_study_table as format_study_table,
    run_study as run_study,
    simulate_trials as simulate_trials,
    trial_keys as trial_keys,
)

