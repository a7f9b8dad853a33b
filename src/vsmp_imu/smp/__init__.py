"""The Semantic Motion Program room: schema, repair, aggregation, refinement,
augmentation, interventions, verbalization and the activity library.

The verbs live in their modules (`vsmp_imu.smp.aggregate.aggregate`,
`vsmp_imu.smp.refine.refine`, `vsmp_imu.smp.intervene.intervene`,
`vsmp_imu.smp.verbalize.verbalize`); this package exports the types.
"""

from vsmp_imu.smp.aggregate import AggregationResult, edit_similarity
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.io import load_smp, save_smp, smp_from_dict
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry
from vsmp_imu.smp.refine import Correction, Refiner, RefineResult
from vsmp_imu.smp.repair import RepairReport, RepairResult, parse_response
from vsmp_imu.smp.schema import SMP, smp_json_schema

__all__ = [
    "SMP", "ActivityLibrary", "AggregationResult", "Correction", "LibraryEntry", "RefineResult",
    "Refiner", "RepairReport", "RepairResult", "SMPAugmenter", "edit_similarity", "load_smp",
    "parse_response", "save_smp", "smp_from_dict", "smp_json_schema",
]
