"""Helpers shared by the subcommands."""

from __future__ import annotations

import argparse


def file_backend() -> None:
    """``--plot`` only writes a file: the non-interactive backend, chosen before pyplot is
    imported (the library itself never chooses one)."""
    import matplotlib

    matplotlib.use("Agg")


def noise_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sigma-um", type=float, default=0.1, help="pose noise σ, translation (µm)")
    p.add_argument("--sigma-arcsec", type=float, default=0.1, help="pose noise σ, angles (″)")
