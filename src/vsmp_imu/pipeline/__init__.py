"""Algorithm 1 end to end: SMP sources, per-sample synthesis, fold-level grounding and filtering."""
