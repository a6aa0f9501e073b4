"""Perception: depth -> point clouds -> per-object segments."""
