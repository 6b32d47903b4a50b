"""The paper's numbers that reports put next to fbil's (Pirotta et al., ICLR 2024).

Per-task returns: Tables 5-7 (K = 1, mean over repetitions and 10 FB models), for the
expert, the eight FB-IL methods and three baselines (`../shared/paper_tables.json` holds
every algorithm). Domain mean imitation scores: computed from Tables 5-7 (SPEC §6);
tests/evaluation/test_paper.py recomputes them from the returns here. Times: Table 8 (GPU).
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
WALKER_TASKS = ("flip", "run", "spin", "stand", "walk")
CHEETAH_TASKS = ("run", "run_backward", "walk", "walk_backward")
QUADRUPED_TASKS = ("jump", "run", "stand", "walk")

# Tables 5 (maze), 6 (walker, cheetah) and 7 (quadruped): one row per method, in the
# domain's task order.
_ROWS: dict[str, tuple[tuple[str, ...], dict[str, tuple[float, ...]]]] = {
    "point_mass_maze": (
        MAZE_TASKS,
        {
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
        },
    ),
    "walker": (
        WALKER_TASKS,
        {
            "expert": (977.2, 845.7, 986.2, 987.5, 978.7),
            "bcfb": (579.7, 262.2, 793.6, 742.9, 891.5),
            "erfb": (552.0, 281.2, 814.4, 721.7, 836.3),
            "rerfb": (553.1, 343.9, 900.3, 672.5, 735.4),
            "bbellfb": (642.6, 322.1, 896.0, 720.7, 789.2),
            "fmfb": (606.5, 228.1, 836.4, 706.3, 808.9),
            "fblossfb": (643.3, 282.7, 910.6, 706.1, 811.1),
            "dmfb": (614.1, 256.0, 824.6, 694.3, 832.8),
            "goalfb": (593.6, 275.4, 903.7, 715.4, 820.3),
            "td3il": (673.7, 293.4, 973.0, 875.5, 736.0),
            "goal-td3": (593.2, 216.8, 859.8, 908.5, 865.3),
            "bc": (28.3, 26.3, 21.5, 166.7, 27.2),
        },
    ),
    "cheetah": (
        CHEETAH_TASKS,
        {
            "expert": (910.9, 627.9, 992.3, 989.9),
            "bcfb": (176.6, 184.5, 646.9, 629.4),
            "erfb": (303.4, 207.4, 888.7, 885.9),
            "rerfb": (252.0, 228.2, 845.8, 854.8),
            "bbellfb": (305.0, 231.8, 674.9, 829.0),
            "fmfb": (290.9, 210.3, 468.1, 834.4),
            "fblossfb": (299.3, 237.7, 632.4, 821.6),
            "dmfb": (291.1, 206.9, 473.4, 836.9),
            "goalfb": (301.4, 205.7, 874.8, 887.4),
            "td3il": (214.1, 347.9, 861.3, 968.8),
            "goal-td3": (83.5, 171.3, 779.8, 653.1),
            "bc": (62.2, 88.6, 237.0, 675.3),
        },
    ),
    "quadruped": (
        QUADRUPED_TASKS,
        {
            "expert": (894.1, 934.0, 971.6, 965.7),
            "bcfb": (784.2, 332.4, 967.3, 800.2),
            "erfb": (798.5, 437.3, 971.1, 703.4),
            "rerfb": (632.2, 393.8, 864.4, 649.6),
            "bbellfb": (629.8, 338.3, 941.3, 762.9),
            "fmfb": (534.1, 241.0, 782.3, 612.1),
            "fblossfb": (643.8, 323.0, 935.3, 768.5),
            "dmfb": (543.7, 246.4, 771.1, 607.3),
            "goalfb": (776.6, 465.5, 949.8, 768.6),
            "td3il": (808.2, 552.6, 855.1, 813.8),
            "goal-td3": (732.4, 426.6, 946.6, 760.7),
            "bc": (156.2, 197.5, 429.8, 295.3),
        },
    ),
}
PAPER_RETURNS: dict[str, dict[str, dict[str, float]]] = {
    domain: {method: dict(zip(tasks, row, strict=True)) for method, row in rows.items()}
    for domain, (tasks, rows) in _ROWS.items()
}

# Domain means of the imitation score (%), K = 1: the mean over the domain's tasks of the
# method's return over the expert's (SPEC §6, from Tables 5-7).
_SCORE_METHODS = (
    "erfb",
    "rerfb",
    "bcfb",
    "fmfb",
    "dmfb",
    "bbellfb",
    "fblossfb",
    "goalfb",
    "td3il",
    "goal-td3",
    "bc",
)
_SCORE_ROWS = {
    "point_mass_maze": (72.8, 74.6, 76.5, 44.2, 42.6, 48.6, 46.1, 88.6, 65.1, 84.8, 49.4),
    "walker": (66.2, 66.4, 67.4, 65.6, 66.4, 69.7, 69.2, 68.2, 73.2, 70.8, 5.6),
    "cheetah": (61.3, 58.9, 44.4, 49.2, 49.3, 55.5, 54.4, 60.9, 65.9, 45.3, 28.3),
    "quadruped": (77.2, 67.3, 76.4, 57.4, 57.4, 70.6, 70.6, 78.5, 80.5, 75.9, 28.4),
}
PAPER_SCORES: dict[str, dict[str, float]] = {
    domain: dict(zip(_SCORE_METHODS, row, strict=True)) for domain, row in _SCORE_ROWS.items()
}

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
