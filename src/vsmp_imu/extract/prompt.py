"""The extraction prompt and JSON schema, verbatim from the paper (appendix "VLM-Based SMP
Extraction"), and the short yes/no question used to check source clips.

The appendix prompt is sent unchanged, followed by the line "The required JSON
schema is:" and the schema block. LaTeX math in the paper (`$[0,1]$`) is
written as plain text here. A label hint and the clip timing, when used, are
separate text parts after the prompt, so the prompt itself never changes.
"""

from __future__ import annotations

import hashlib

PROMPT_TEMPLATE = """\
You are given a video clip of one human activity. Extract a Semantic Motion Program (SMP) that describes the activity for wearable IMU synthesis.

Return only valid JSON matching the schema below. Do not include extra commentary.

Identify:
(1) the activity label,
(2) the ordered motion primitives,
(3) primitive durations or relative phase lengths if visible,
(4) involved body parts,
(5) temporal structure, including repetition count, periodicity, ordering, and transitions,
(6) execution attributes, including tempo, amplitude, dominant side, symmetry, and global displacement,
(7) object or contact information,
(8) invariant fields that must not change during augmentation,
(9) variant fields that may change while preserving the activity label,
(10) field-wise uncertainty scores in [0,1], where 0 means high confidence and 1 means maximum uncertainty.

Use conservative uncertainty values when the video is occluded, ambiguous, cropped, or contains multiple possible activities."""

SCHEMA_INTRO = "The required JSON schema is:"

SCHEMA_TEXT = """\
{
  "activity_label": "string",

  "motion_primitives": [
    {
      "name": "string",
      "order_index": "integer",
      "description": "string",
      "body_parts": ["string"],
      "relative_duration": "float_or_unknown",
      "contact": ["string"]
    }
  ],

  "primitive_sequence": ["string"],

  "primitive_durations": {
    "type": "absolute|relative|unknown",
    "values": ["float_or_unknown"]
  },

  "body_parts": {
    "mandatory": ["string"],
    "optional": ["string"],
    "dominant_moving_segments": ["string"]
  },

  "temporal_structure": {
    "is_repetitive": "boolean",
    "repetition_count": "integer_or_unknown",
    "periodicity": "none|single|cyclic|unknown",
    "ordering": "ordered|weakly_ordered|unordered",
    "transition_type": "discrete|continuous|unknown"
  },

  "execution_attributes": {
    "tempo": "slow|medium|fast|unknown",
    "amplitude": "small|medium|large|unknown",
    "dominant_side": "left|right|bilateral|none|unknown",
    "symmetry": "symmetric|asymmetric|unknown",
    "global_displacement": "stationary|small|large|unknown"
  },

  "object_contact": {
    "objects": ["string"],
    "body_contact": ["string"],
    "environment_contact": ["string"],
    "required_contact": ["string"]
  },

  "constraints": {
    "invariant_fields": [
      "activity_label",
      "primitive_sequence",
      "mandatory_body_parts",
      "required_contact",
      "stationary_or_mobile"
    ],
    "variant_fields": [
      "tempo",
      "amplitude",
      "repetition_count",
      "primitive_duration",
      "dominant_side",
      "symmetry",
      "global_displacement"
    ],
    "rules": {
      "preserve_activity_label": true,
      "preserve_core_primitive_order": true,
      "preserve_mandatory_body_parts": true,
      "preserve_required_contact": true,
      "dominant_side_swap_allowed_only_if_side_agnostic": true,
      "symmetry_change_allowed_only_if_label_preserving": true,
      "global_displacement_change_must_preserve_stationary_or_mobile_semantics": true
    }
  },

  "uncertainty": {
    "activity_label": "float",
    "motion_primitives": "float",
    "primitive_duration": "float",
    "body_parts": "float",
    "temporal_structure": "float",
    "repetition_count": "float",
    "tempo": "float",
    "amplitude": "float",
    "dominant_side": "float",
    "symmetry": "float",
    "global_displacement": "float",
    "object_contact": "float"
  }
}"""

LABEL_HINT_TEMPLATE = ("Label hint: the dataset labels this clip \"{label}\". Use it as the activity "
                       "label if it is consistent with what the video shows.")
TIMING_TEMPLATE = ("The clip lasts {duration_s:.2f} s. The {n} frames that follow are sampled "
                   "uniformly in time, {step_s:.3f} s apart, in temporal order.")

# Source-pool check (paper, "Source Video Collection for IMU-Only Target Datasets").
CHECK_TEMPLATE = """\
You are given frames sampled uniformly from a video clip. Decide whether the clip shows a person performing the activity "{activity}" as its dominant action. Answer "no" when the activity is absent, when it is not the dominant action, when several competing actions are present, or when the visible activity does not match the name.

Return only valid JSON of the form {{"answer": "yes" or "no", "confidence": a number in [0,1], "reason": "one short sentence"}}. Do not include extra commentary."""


def smp_prompt() -> str:
    """The full extraction prompt: the appendix template and the schema block."""
    return f"{PROMPT_TEMPLATE}\n\n{SCHEMA_INTRO}\n\n{SCHEMA_TEXT}"


def prompt_sha256(*parts: str) -> str:
    """Hash of the prompt texts that define a request (part of every cache key)."""
    return hashlib.sha256("\x1f".join(parts).encode("utf-8")).hexdigest()
