"""Benchmarks: episodes, metrics, tables, plots, timing scripts."""
