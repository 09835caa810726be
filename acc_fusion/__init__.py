"""acc_fusion: forward-collision-warning research by simulation."""

__version__ = "0.1.0"
