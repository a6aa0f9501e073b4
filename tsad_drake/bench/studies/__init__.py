"""Studies and timing scripts behind figures in docs/ (`python -m tsad_drake.bench.studies.NAME`)."""
