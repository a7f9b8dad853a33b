"""The Semantic Motion Program room: schema, repair, aggregation, refinement,
augmentation, interventions, verbalization and the activity library."""

from vsmp_imu.smp.io import load_smp, save_smp, smp_from_dict
from vsmp_imu.smp.schema import SMP, smp_json_schema

__all__ = ["SMP", "load_smp", "save_smp", "smp_from_dict", "smp_json_schema"]
