"""Multi-channel matrix pencil (ESPRIT) for free-decay records: the library's
(:mod:`stewart_jax.cable_robot._pencil`), which the cabin-record model uses to start its fits."""

from stewart_jax.cable_robot._pencil import PencilModes, matrix_pencil, record_modes

__all__ = ["PencilModes", "matrix_pencil", "record_modes"]
