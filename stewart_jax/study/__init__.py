"""Reproductions of the papers' simulation studies, as seeded Monte Carlo runs.

:func:`run_study` is Wang et al. (2018) §3, Table 2 ("Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5)): chunked,
checkpointed, resumable and split over devices or hosts. The statistics of method comparisons
over seeds (Wilcoxon signed-rank test, bootstrap interval of the median ratio, Moré–Wild data
profiles, budget curves) are in ``_statistics``.
"""

from ._statistics import (
    RatioInterval as RatioInterval,
    WilcoxonResult as WilcoxonResult,
    best_within_budgets as best_within_budgets,
    bootstrap_median_ratio as bootstrap_median_ratio,
    data_profiles as data_profiles,
    evaluations_to_solve as evaluations_to_solve,
    paired_comparison as paired_comparison,
    wilcoxon_signed_rank as wilcoxon_signed_rank,
)
from ._study import (
    BEFORE as BEFORE,
    METHOD_LABELS as METHOD_LABELS,
    PAPER_TABLE2 as PAPER_TABLE2,
    format_study_table as format_study_table,
    run_study as run_study,
    simulate_trials as simulate_trials,
    trial_keys as trial_keys,
)
