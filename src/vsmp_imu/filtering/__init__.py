"""The filtering room: motion plausibility, class faithfulness and redundancy.

Every verdict is stored with its reason (paper, "Quality filtering" and
appendix "Quality Filtering")."""
