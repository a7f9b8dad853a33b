"""Baselines that make synthetic training windows for the HAR harness (`vsmp_imu.har`):
Classical Aug here; the video- and text-driven baselines live beside it."""

from vsmp_imu.baselines.classical import ClassicalAugmentation, sensor_triplets

__all__ = ["ClassicalAugmentation", "sensor_triplets"]
