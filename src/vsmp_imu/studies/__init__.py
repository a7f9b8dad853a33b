"""The studies room: the paper's analyses beyond HAR training runs.

- `control`: end-to-end SMP controllability (motion, raw IMU, grounded IMU);
  `control_report` writes its report and figure; `imu_measure` holds the
  IMU-side measurements, `targets` the grounding targets and `retention` the
  label-retention classifier.
- `audit`: SMP extraction audit against reference SMPs; `audit_report`.
- `case`: the qualitative case-study figure of one activity.
- `ablation`: the strictly matched caption-SMP 2x2 (`matched`), component,
  sensor-grounding and alpha ablations; `ablation_report`.
- `granularity`: per-class and per-group results under an activity taxonomy
  (`taxonomies/*.yaml`); `granularity_report`.
- `realism`: class-wise centroid distances in DeepConvLSTM embeddings;
  `realism_report`.
- `methods`: the synthetic methods as the `evaluate` command registers them.
- `report`: output helpers shared by every study; `folders`: the output
  folder each study takes (`-o`) before its work.

See docs/studies.md.
"""
