"""Names of the VSMP-IMU method and its ablation variants (light: no heavy imports)."""

# Ablation variants (paper, "Ablation Study"): name -> GenerationConfig switches.
ABLATIONS: dict[str, tuple[str, dict[str, bool]]] = {
    "vsmp": ("VSMP-IMU", {}),
    "vsmp-no-refine": ("w/o refinement", {"refine": False}),
    "vsmp-no-uncertainty": ("w/o uncertainty-aware constraints", {"uncertainty_conditioned": False}),
    "vsmp-no-adaptation": ("w/o IMU adaptation", {"sim_in_the_loop": False, "rank_grounding": False}),
    "vsmp-no-filter": ("w/o filtering", {"quality_filter": False}),
    "vsmp-sim-only": ("Simulation-in-the-loop only", {"rank_grounding": False}),
    "vsmp-rank-only": ("Rank-based grounding only", {"sim_in_the_loop": False}),
    "vsmp-class-rank": ("VSMP-IMU, per-class rank grounding", {"per_class_rank": True}),
    "vsmp-pooled-rank": ("VSMP-IMU, pooled rank grounding", {"per_class_rank": False}),
}
