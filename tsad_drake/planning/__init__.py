"""Symbolic planning: state, point-cloud simulation, feasibility models, TSAD and baselines (no Drake)."""
