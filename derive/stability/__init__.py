"""Stability where the paper's analytical methods stop: Floquet multipliers of stationary
rotations and of periodic bouncing, long perturbed runs, stability charts."""
