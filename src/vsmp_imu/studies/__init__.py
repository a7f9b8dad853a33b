"""The studies room: the paper's analyses beyond HAR training runs.

- `control`: end-to-end SMP controllability (motion, raw IMU, grounded IMU);
  `control_report` writes its report and figure; `imu_measure` holds the
  IMU-side measurements, `targets` the grounding targets and `retention` the
  label-retention classifier.
- `audit`: SMP extraction audit against reference SMPs; `audit_report`.
- `case`: the qualitative case-study figure of one activity.
- `report`: output helpers shared by every study.

See docs/studies.md.
"""
