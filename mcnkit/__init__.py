"""mcnkit: map completion network SLAM (MCN-SLAM) — robot-log I/O, grid FastSLAM, map completion networks,
Rerun recordings and the paper's experiments."""

__version__ = "0.1.0"
