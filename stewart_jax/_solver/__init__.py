"""Calibration optimisers. Import them from ``stewart_jax``."""
