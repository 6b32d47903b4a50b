"""The paper's numbers that reports put next to fbil's (Pirotta et al., ICLR 2024).

Maze per-task returns: Table 5 (K = 1, mean over repetitions and 10 FB models).
Domain mean imitation scores: computed from Tables 5-7 (SPEC §6). Times: Table 8 (GPU).
"""

from __future__ import annotations

MAZE_TASKS = (
    "fast_slow",
    "loop",
    "reach_bottom_left",
    "reach_bottom_left_long",
    "reach_bottom_right",
    "reach_top_left",
    "reach_top_right",
    "square",
)

# Table 5, maze, in MAZE_TASKS order.
_MAZE_ROWS = {
    "expert": (935.5, 912.4, 813.4, 666.4, 710.3, 949.3, 813.0, 952.9),
    "bcfb": (392.8, 846.8, 734.5, 156.4, 548.5, 962.4, 758.1, 873.4),
    "erfb": (347.1, 697.6, 817.4, 77.3, 527.7, 956.5, 819.5, 771.9),
    "rerfb": (284.8, 637.8, 776.1, 347.7, 570.6, 945.5, 760.1, 718.4),
    "bbellfb": (236.2, 648.8, 495.8, 53.9, 313.3, 776.5, 412.4, 445.1),
    "fmfb": (221.2, 598.6, 356.5, 129.9, 178.8, 754.0, 432.0, 413.9),
    "fblossfb": (219.4, 638.0, 377.0, 20.7, 375.5, 824.9, 297.3, 473.5),
    "dmfb": (229.8, 569.1, 251.5, 163.8, 277.7, 746.9, 271.5, 447.8),
    "goalfb": (572.9, 818.1, 799.7, 543.9, 617.6, 954.6, 793.7, 885.5),
    "td3il": (104.9, 752.2, 830.5, 11.1, 668.8, 963.4, 829.6, 244.3),
    "goal-td3": (824.5, 800.9, 781.5, 473.6, 335.4, 948.6, 760.1, 904.6),
    "bc": (451.7, 506.9, 346.9, 263.4, 167.5, 476.3, 452.6, 757.8),
}
PAPER_RETURNS: dict[str, dict[str, dict[str, float]]] = {
    "point_mass_maze": {
        method: dict(zip(MAZE_TASKS, row, strict=True)) for method, row in _MAZE_ROWS.items()
    }
}

# Domain means of the imitation score (%), K = 1 (SPEC §6, from Tables 5-7).
PAPER_SCORES: dict[str, dict[str, float]] = {
    "point_mass_maze": {
        "erfb": 72.8,
        "rerfb": 74.6,
        "bcfb": 76.5,
        "fmfb": 44.2,
        "dmfb": 42.6,
        "bbellfb": 48.6,
        "fblossfb": 46.1,
        "goalfb": 88.6,
        "td3il": 65.1,
        "goal-td3": 84.8,
        "bc": 49.4,
    },
    "walker": {"erfb": 66.2, "rerfb": 66.4, "bcfb": 67.4, "fmfb": 65.6, "dmfb": 66.4},
    "cheetah": {"erfb": 61.3, "rerfb": 58.9, "bcfb": 44.4, "fmfb": 49.2, "dmfb": 49.3},
    "quadruped": {"erfb": 77.2, "rerfb": 67.3, "bcfb": 76.4, "fmfb": 57.4, "dmfb": 57.4},
}
for _domain, _extra in {
    "walker": {"bbellfb": 69.7, "fblossfb": 52.6, "goalfb": 68.2},
    "cheetah": {"bbellfb": 55.5, "fblossfb": 54.4, "goalfb": 60.9},
    "quadruped": {"bbellfb": 70.6, "fblossfb": 70.6, "goalfb": 78.5},
}.items():
    PAPER_SCORES[_domain].update(_extra)

# Table 8: time to an imitation policy on the paper's GPUs, averaged over environments.
PAPER_TIMES = {
    "erfb": "< 5 s",
    "rerfb": "< 5 s",
    "goalfb": "< 5 s",
    "bcfb": "1 min",
    "fmfb": "3 min",
    "dmfb": "3 min",
    "bbellfb": "4 min",
    "fblossfb": "4 min",
    "td3il": "7 h 3 min",
    "bc": "3 h 14 min",
}
