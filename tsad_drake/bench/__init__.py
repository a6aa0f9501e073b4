"""Benchmarks: episodes on a process pool or Ray, metrics, tables, plots, config sweeps."""
