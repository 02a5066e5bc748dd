"""The joint centres of Wang H., Cao X. et al., "Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018,
Table 1 (mm; rows: rod 1..6): the nominal design and the "actual" mechanism of the simulation
study, upper joints ``Ac_i`` in frame A and lower joints ``Bc_i`` in frame B."""

import numpy as np

NOMINAL_UPPER = np.array(
    [
        [103.6, 34.6, 84.7],
        [-21.5, 107.1, 84.7],
        [-81.8, 72.4, 84.7],
        [-81.8, -72.4, 84.7],
        [-21.5, -107.1, 84.7],
        [103.6, -34.6, 84.7],
    ]
)
NOMINAL_LOWER = np.array(
    [
        [67.9, 61.8, -132.1],
        [19.6, 89.7, -132.1],
        [-87.5, 27.9, -132.1],
        [-87.5, -27.9, -132.1],
        [19.6, -89.7, -132.1],
        [67.9, -61.8, -132.1],
    ]
)
ACTUAL_UPPER = np.array(
    [
        [103.7, 37.2, 79.2],
        [-20.8, 106.7, 81.1],
        [-83.7, 72.1, 90.9],
        [-77.2, -76.1, 89.8],
        [-21.1, -108.2, 85.1],
        [102.2, -35.8, 86.7],
    ]
)
ACTUAL_LOWER = np.array(
    [
        [69.7, 63.7, -131.8],
        [16.1, 90.2, -129.9],
        [-86.5, 27.8, -131.7],
        [-89.1, -28.3, -134.7],
        [20.3, -93.0, -135.3],
        [65.3, -68.7, -130.3],
    ]
)
