"""Studies and timing scripts behind figures in docs/ (`python -m studies.NAME`)."""
