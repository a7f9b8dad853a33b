"""VSMP-IMU: video-grounded Semantic Motion Programs for synthetic wearable IMU data."""

__version__ = "0.1.0"
