"""The extract room: video -> SMP.

- `frames`: clip-level uniform frame sampling (appendix presets), contact sheets;
- `client`, `vlm`, `prompt`, `cache`: the VLM extractor (any OpenAI-compatible
  endpoint, five queries, repair -> aggregate -> refine, failure accounting);
- `landmarks`, `retarget`, `posemeasure`, `calibrate`, `pose`, `fuse`: the
  offline pose extractor (MediaPipe -> SMPL-22 motion -> measured SMP fields
  with uncertainties) and the fused mode;
- `pool`: source clip pools for IMU-only datasets and their manifest.

OpenCV and MediaPipe (the `video` extra) are imported only when used.
"""

from vsmp_imu.extract.client import VLMClient, api_key_from_env
from vsmp_imu.extract.frames import PRESETS, FramePreset, FrameSampler, SampledFrames
from vsmp_imu.extract.pose import PoseExtraction, PoseExtractor
from vsmp_imu.extract.vlm import ExtractionResult, FailureCounts, VLMExtractor

__all__ = [
    "PRESETS", "ExtractionResult", "FailureCounts", "FramePreset", "FrameSampler", "PoseExtraction",
    "PoseExtractor", "SampledFrames", "VLMClient", "VLMExtractor", "api_key_from_env",
]
