"""The grounding room: target statistics (D_stat, D_rank), simulation-in-the-loop
calibration (bounded CEM over eta), convention alignment (gamma) and rank grounding."""
